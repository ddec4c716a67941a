"""The motion gate of the passive watch on synthetic samples: a transit shows in the surge
effort, the coast after it lasts as long as drag needs at the slow end of the prior, a DVL
decides the speed where it reports, a turn shows in the heading and a heading loop's
hunting does not."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from trimd.core.model import restoring_matrix
from trimd.core.motion import (
    COASTING,
    HYDRO_SPREAD,
    MAX_SPEED_M_S,
    MOVING_DVL,
    TRANSIT,
    TURNING,
    MotionGate,
    Window,
)
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Attitude, Velocity
from trimd.core.segment import nominal_q

THRUST_N = 27.0          # the simulated Heavy's surge effort at 35 % forward stick
CRUISE_M_S = 0.5
TRANSIT_S = 20.0
RATE_HZ = 10.0


def _gate(profile: Profile) -> MotionGate:
    return MotionGate(profile, nominal_q(profile))


def _level(t: float, psi: float = 0.0, r: float = 0.0) -> Attitude:
    return Attitude(t, 0.0, 0.0, psi, 0.0, 0.0, r)


def _surge(gate: MotionGate, t: float, force: float) -> None:
    gate.effort(t, np.array([force, 0.0, 0.0, 0.0, 0.0, 0.0]))


def _cruise_thrust(profile: Profile) -> float:
    """The surge force [N] that holds the profile's vehicle at CRUISE_M_S."""
    return (abs(profile.linear_damping[0]) * CRUISE_M_S
            + abs(profile.quadratic_damping[0]) * CRUISE_M_S**2)


def _speed_after_transit(profile: Profile, thrust: float) -> tuple[float, float]:
    """The coasting model at the slow end of the prior, integrated independently: its
    speed at the end of a transit of ``thrust`` [N], and the time [s] after that at which
    its speed falls below MAX_SPEED_M_S."""
    m = (1 + HYDRO_SPREAD) * (profile.mass_kg + profile.added_mass[0])
    d1 = (1 - HYDRO_SPREAD) * abs(profile.linear_damping[0])
    d2 = (1 - HYDRO_SPREAD) * abs(profile.quadratic_damping[0])

    def f(t: float, u: np.ndarray) -> np.ndarray:
        force = thrust if t < TRANSIT_S else 0.0
        return (force - d1 * u - d2 * np.abs(u) * u) / m

    slow = solve_ivp(f, (0.0, TRANSIT_S + 120), [0.0], max_step=0.01, dense_output=True)
    t = np.arange(TRANSIT_S, TRANSIT_S + 120, 0.001)
    u = slow.sol(t)[0]
    return float(u[0]), float(t[np.argmax(u < MAX_SPEED_M_S)] - TRANSIT_S)


@pytest.mark.parametrize("name", ["bluerov2-heavy", "sabertooth-dh2"])
def test_the_coast_after_a_transit_lasts_until_drag_has_taken_the_speed(name: str) -> None:
    profile = load_profile(name)
    gate = _gate(profile)
    thrust = _cruise_thrust(profile)
    speed_at_stop, coast_s = _speed_after_transit(profile, thrust)
    assert speed_at_stop > CRUISE_M_S      # the slow end of the prior: less drag
    seen: list[tuple[float, str | None]] = []
    for k in range(int((TRANSIT_S + coast_s + 10) * RATE_HZ)):
        t = k / RATE_HZ
        _surge(gate, t, thrust if t < TRANSIT_S else 0.0)
        gate.attitude(_level(t))
        seen.append((t, gate.why_moving(t)))
    whys = dict(seen)
    assert whys[0.0] == TRANSIT and whys[TRANSIT_S - 0.1] == TRANSIT
    rest = next(t for t, why in seen if t > TRANSIT_S and why is None)
    assert rest == pytest.approx(TRANSIT_S + coast_s, abs=2 / RATE_HZ)
    assert all(why is None for t, why in seen if t >= rest)
    # the transit's effort mean fades within its window; the coast goes on after it
    assert COASTING in {why for t, why in seen if TRANSIT_S < t < rest}


def test_a_dvl_decides_the_speed_where_it_reports(bluerov: Profile) -> None:
    """After the same transit a DVL that shows the vehicle stopped within 3 s overrules
    the slower model; a vehicle drifting at 0.2 m/s without any effort is moving."""
    gate = _gate(bluerov)
    rest = None
    for k in range(int(60 * RATE_HZ)):
        t = k / RATE_HZ
        _surge(gate, t, THRUST_N if t < TRANSIT_S else 0.0)
        u = 0.5 if t < TRANSIT_S else 0.5 * math.exp(-(t - TRANSIT_S) / 0.5)
        gate.velocity(Velocity(t, u, 0.0, 0.0))
        gate.attitude(_level(t))
        if t > TRANSIT_S and rest is None and gate.why_moving(t) is None:
            rest = t
    # the 2 s mean of the DVL's speed is below 0.1 m/s 2.0–2.3 s after the stop
    assert rest is not None and TRANSIT_S + 1.9 <= rest <= TRANSIT_S + 2.4
    drifting = _gate(bluerov)
    for k in range(50):
        t = k / RATE_HZ
        _surge(drifting, t, 0.0)
        drifting.velocity(Velocity(t, 0.0, 0.2, 0.0))
        drifting.attitude(_level(t))
    assert drifting.why_moving(4.9) == MOVING_DVL


def test_a_turn_breaks_the_stretch_and_heading_hunting_does_not(bluerov: Profile) -> None:
    """A 60° turn in 6 s at rest is seen within 3 s of its end and the gate is at rest
    again at once (the stretch restarts there); a heading hunting ±17° at a 10 s period
    (the simulated Heavy's heading loop in its thrusters' dead band) never turns."""
    gate = _gate(bluerov)
    turn_at, turn_s, turn_rad = 40.0, 6.0, math.radians(60.0)
    turning = []
    for k in range(int(80 * RATE_HZ)):
        t = k / RATE_HZ
        x = min(max((t - turn_at) / turn_s, 0.0), 1.0)
        _surge(gate, t, 0.0)
        gate.attitude(_level(t, psi=turn_rad * x))
        if gate.why_moving(t) == TURNING:
            turning.append(t)
    assert turning and turn_at < turning[0] <= turn_at + turn_s + 3.0
    assert len(turning) <= 2           # a break, not a long stretch of motion
    hunting = _gate(bluerov)
    amplitude, period = math.radians(17.0), 10.0
    for k in range(int(300 * RATE_HZ)):
        t = k / RATE_HZ
        w = 2 * math.pi / period
        _surge(hunting, t, 0.0)
        hunting.attitude(_level(t, amplitude * math.sin(w * t), amplitude * w * math.cos(w * t)))
        assert hunting.why_moving(t) is None, t


def test_effort_the_trim_leaves_unexplained_is_no_motion(sabertooth: Profile) -> None:
    """At a 20° tilt the prior's restoring forces miss a payload's weight share: a steady
    surge residual below the force floor neither counts as a transit nor drives the
    coasting model, however long it lasts; one above it is a transit."""
    gate = _gate(sabertooth)
    below = 0.8 * gate.force_floor
    tilted = Attitude(0.0, math.radians(20), math.radians(20), 0.0, 0.0, 0.0, 0.0)
    g_x = float((restoring_matrix(tilted.phi, tilted.theta) @ nominal_q(sabertooth))[0])
    for k in range(int(120 * RATE_HZ)):
        t = k / RATE_HZ
        gate.attitude(Attitude(t, tilted.phi, tilted.theta, 0.0, 0.0, 0.0, 0.0))
        gate.effort(t, np.array([g_x + below, 0.0, 0.0, 0.0, 0.0, 0.0]))
        assert gate.why_moving(t) is None, t
    for k in range(int(3 * RATE_HZ)):
        t = 120.0 + k / RATE_HZ
        gate.effort(t, np.array([g_x + 1.5 * gate.force_floor, 0.0, 0.0, 0.0, 0.0, 0.0]))
    assert gate.why_moving(t) == TRANSIT


def test_a_window_gives_the_mean_and_slope_of_its_samples_and_forgets_a_nan() -> None:
    """The running sums agree with numpy over the samples left in the window (also after
    many turnovers, far from the time origin), and a NaN counts only while it is in it."""
    rng = np.random.default_rng(0)
    w = Window(2)
    t = 1e5
    for k in range(5000):
        t += 0.05 + 0.02 * rng.random()
        w.push((t, 3.0 + rng.standard_normal(), 0.01 * t + rng.standard_normal()), t - 2.0)
        if k % 997 == 996:
            left = np.array(w.items)
            assert np.allclose(w.mean(), left[:, 1:].mean(axis=0), rtol=0, atol=1e-9)
            assert w.mean(since=left[3, 0]) == pytest.approx(left[3:, 1:].mean(axis=0))
            tt = left[:, 0] - left[:, 0].mean()
            slope = tt @ (left[:, 1] - left[:, 1].mean()) / (tt @ tt)
            assert w.slope() == pytest.approx(slope, abs=1e-9)
    w.push((t + 0.1, math.nan, 0.0), t - 1.9)
    w.push((t + 0.2, 5.0, 1.0), t - 1.8)
    assert math.isnan(w.mean()[0])
    w.clear()   # summed afresh, then a NaN that leaves long before a turnover
    for k in range(40):
        w.push((t + 0.1 * k, math.nan if k == 5 else 5.0, 1.0), t + 0.1 * k - 3.0)
        assert math.isnan(w.mean()[0]) == (5 <= k < 36), k
    assert w.mean() == (5.0, 1.0)
