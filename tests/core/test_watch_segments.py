"""The watch's segments on a synthetic dive of level transits and stops (no stick
telemetry, attitude and depth the same throughout): a segment in every stop, none
touching a transit, none before the coast after a transit is over, each at the true
W − B; the same dive with the transit's effort but no gate merges everything."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.core.test_motion import _speed_after_transit
from tests.helpers import payload_truth
from trimd.core.model import pwm_from_thrust, restoring_forces, thrust_configuration
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import (
    Attitude,
    Depth,
    Health,
    ModeClass,
    Sample,
    Thrusters,
    Velocity,
)
from trimd.core.watch import TrimWatch

TRANSIT_S, TURN_S = 20.0, 4.0
CYCLES = 3
TURN_RAD = math.radians(50.0)
#: per vehicle: the stop [s] (the issue's 40 s for the Heavy; the Sabertooth coasts for
#: up to 42 s at the slow end of its prior) and the transit's surge force [N] (the Heavy's
#: at 35 % stick; the Sabertooth's cruise at 0.5 m/s), and the payload [kg] at a slot
DIVES = {"bluerov2-heavy": (40.0, 27.0, 0.3, "W-aft-ctr"),
         "sabertooth-dh2": (90.0, 125.0, 10.0, "AftSB")}


def _transits(stop_s: float) -> list[tuple[float, float]]:
    return [(stop_s + k * (stop_s + TRANSIT_S), (k + 1) * (stop_s + TRANSIT_S))
            for k in range(CYCLES)]


def _stops(stop_s: float) -> list[tuple[float, float]]:
    return [(k * (stop_s + TRANSIT_S), k * (stop_s + TRANSIT_S) + stop_s)
            for k in range(CYCLES + 1)]


def _dive(profile: Profile, W: float, r_g: np.ndarray, dvl: bool, seed: int = 0
          ) -> list[Sample]:
    """The samples of a level dive (:data:`DIVES`): attitude 10 Hz (0.05° noise),
    thrusters 4 Hz (the restoring effort plus the transit's surge, 1 % noise per
    thruster), depth 5 Hz, health 1 Hz, and a DVL at 5 Hz if asked (0.4 m/s in transit,
    decaying over 1 s)."""
    rng = np.random.default_rng(seed)
    T_pinv = np.linalg.pinv(thrust_configuration(profile.thrusters))
    stop_s, surge_N, _, _ = DIVES[profile.name]
    transits = _transits(stop_s)
    end = _stops(stop_s)[-1][1]
    volts = profile.nominal_voltage_V
    g = restoring_forces(0.0, 0.0, W, profile.buoyancy_N, r_g, profile.r_b_m)

    def heading(t: float) -> float:
        done = sum(min(max((t - (b - TURN_S)) / TURN_S, 0.0), 1.0) for _, b in transits)
        return TURN_RAD * done

    def transit_speed(t: float) -> float:
        for a, b in transits:
            if a <= t < b:
                return 0.4
            if t >= b:
                last = 0.4 * math.exp(-(t - b))
        return last if t >= transits[0][1] else 0.0

    out: list[Sample] = []
    for k in range(int(end * 20)):
        t = k / 20
        if k % 20 == 0:
            out.append(Health(t, True, "ALT_HOLD", True,
                              mode_class=ModeClass.DEPTH_HOLDING))
        if k % 4 == 0:
            out.append(Depth(t, 5.0 + 0.003 * rng.standard_normal()))
            if dvl:
                out.append(Velocity(t, transit_speed(t), 0.0, 0.0))
        if k % 5 == 0:
            surge = surge_N if any(a <= t < b for a, b in transits) else 0.0
            tau = g + np.r_[surge, 0, 0, 0, 0, 0]
            f = T_pinv @ tau * (1 + 0.01 * rng.standard_normal(len(T_pinv)))
            out.append(Thrusters(t, tuple(float(pwm_from_thrust(th.curve, [fi], volts)[0])
                                          for th, fi in zip(profile.thrusters, f, strict=True))))
        if k % 2 == 0:
            noise = math.radians(0.05) * rng.standard_normal(2)
            rate = TURN_RAD / TURN_S if heading(t + 0.05) != heading(t - 0.05) else 0.0
            out.append(Attitude(t, noise[0], noise[1], heading(t), 0.0, 0.0, rate))
    return out


def _watch(profile: Profile, samples: list[Sample]) -> TrimWatch:
    watch = TrimWatch(profile)
    for s in samples:
        watch.feed(s)
    watch.finish()
    return watch


def _truth(profile: Profile) -> tuple[float, np.ndarray]:
    _, _, kg, slot = DIVES[profile.name]
    return payload_truth(profile, kg, np.array(profile.slot(slot).position_m))


@pytest.mark.parametrize(("name", "dvl"), [("bluerov2-heavy", False), ("bluerov2-heavy", True),
                                           ("sabertooth-dh2", False)])
def test_every_stop_gives_a_segment_and_no_transit_does(name: str, dvl: bool) -> None:
    profile = load_profile(name)
    stop_s, surge_N, _, _ = DIVES[name]
    W, r_g = _truth(profile)
    watch = _watch(profile, _dive(profile, W, r_g, dvl))
    spans = [(s.estimate.t_start_s, s.estimate.t_end_s) for s in watch.segments]
    for a, b in _stops(stop_s):
        assert any(a <= t0 and t1 <= b for t0, t1 in spans), ((a, b), spans, watch.rejected)
    assert not [s for s in spans for a, b in _transits(stop_s) if s[0] < b and s[1] > a]
    # after a transit nothing counts until the coast is over (the DVL's speed, else the
    # slow model's: 2.3 s on the Heavy, 42 s on the Sabertooth), and then the settling
    # test wants min_steady_s
    coast = 2.0 if dvl else _speed_after_transit(profile, surge_N)[1]
    settle = profile.procedure.min_steady_s
    for _, b in _transits(stop_s):
        first = min(t0 for t0, _ in spans if t0 > b)
        assert first >= b + coast + settle, (b, first, coast)
    true_net = W - profile.buoyancy_N
    for s in watch.segments:
        assert abs(s.estimate.q[0] - true_net) < 3 * s.estimate.q_std[0]


def test_without_breaks_the_level_stretch_spans_transits_and_stops(
        bluerov: Profile, monkeypatch: pytest.MonkeyPatch) -> None:
    """The issue's dive, seen by attitude alone (the gate never says moving): the level
    plateau spans transits and stops, and no stop becomes a segment of its own."""
    from trimd.core.motion import MotionGate
    monkeypatch.setattr(MotionGate, "why_moving", lambda self, t_s: None)
    W, r_g = _truth(bluerov)
    watch = _watch(bluerov, _dive(bluerov, W, r_g, dvl=False))
    spans = [(s.estimate.t_start_s, s.estimate.t_end_s) for s in watch.segments]
    stops = _stops(DIVES[bluerov.name][0])
    inside = [any(a <= t0 and t1 <= b for a, b in stops) for t0, t1 in spans]
    assert inside.count(True) < len(stops) - 1, (spans, watch.rejected)
