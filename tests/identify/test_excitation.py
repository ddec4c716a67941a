"""Excitation signal design and the excite state machine's safety rules."""

from __future__ import annotations

import math

import numpy as np
import pytest

from trimd.core.events import Abort, Confirm, Phase, Tick
from trimd.core.profile import Profile
from trimd.core.samples import (
    Attitude,
    Depth,
    Health,
    ModeClass,
    OpenLoop,
    PilotInput,
    Release,
    Thrusters,
)
from trimd.identify.experiment import Excite
from trimd.identify.model import HYDRO_NAMES, STAGES, prior_values
from trimd.identify.signals import TARGET_SPEED, axis_authority, axis_forces, design_signal


@pytest.mark.parametrize("stage", list(STAGES))
@pytest.mark.parametrize("kind", ["multistep", "prbs", "doublet"])
def test_signal_moves_only_the_stage_axes_within_limits(sabertooth: Profile, stage: str,
                                                       kind: str) -> None:
    sig = design_signal(sabertooth, stage, kind=kind, duration_s=120.0, seed=4)
    assert np.all(np.abs(sig.levels) <= 1.0)
    moving = {i for i in range(6) if np.ptp(sig.levels[:, i]) > 0}
    assert moving == set(STAGES[stage].axes)
    assert sig.at(500.0) == sig.offsets


def test_velocity_axes_have_a_nonzero_mean_and_several_levels(sabertooth: Profile) -> None:
    sig = design_signal(sabertooth, "uvr", duration_s=600.0, seed=1)
    durations = np.diff(np.r_[sig.t_s, sig.duration_s])
    for axis in (0, 1, 5):
        x = sig.levels[:, axis]
        mean = float(np.sum(x * durations) / sig.duration_s)
        assert mean > 0.1 * np.max(np.abs(x))
        assert len(np.unique(np.round(np.abs(x), 6))) >= 3


def test_doublets_keep_position_axes_balanced(bluerov: Profile) -> None:
    sig = design_signal(bluerov, "uwq", duration_s=300.0, seed=2)
    durations = np.diff(np.r_[sig.t_s, sig.duration_s])
    heave = sig.levels[:, 2] - sig.offsets[2]
    # each doublet returns: the net impulse is a small part of the total
    assert abs(np.sum(heave * durations)) < 0.1 * np.sum(np.abs(heave) * durations)


def _ready(e: Excite, t: float = 0.0, mode: str = "MANUAL",
           mode_class: ModeClass = ModeClass.MANUAL) -> list[object]:
    """5.98 s of telemetry at 50 Hz from a vehicle armed in ``mode`` (of ``mode_class``,
    as its driver classed it): the precheck's window."""
    out: list[object] = []
    for k in range(300):
        s = t + 0.02 * k
        out += e.step(Health(s, True, mode, True, mode_class=mode_class))
        out += e.step(Depth(s, 10.0))
        out += e.step(Attitude(s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    return out


def test_no_command_before_confirmation_then_inputs(sabertooth: Profile) -> None:
    sig = design_signal(sabertooth, "uvr", duration_s=10.0, seed=0)
    e = Excite(sabertooth, sig)
    out = _ready(e)
    assert e.phase is Phase.CONFIRM
    assert not [o for o in out if isinstance(o, OpenLoop | Release)]
    started = e.step(Confirm())
    assert e.progress.phase is Phase.COLLECT
    assert isinstance(started[-1], OpenLoop)
    assert started[-1].axes == sig.at(0.0)


def test_confirm_checks_the_vehicle_again(sabertooth: Profile) -> None:
    """As the trim's (the machines' one base, trimd.core.phases): the go given in CONFIRM
    runs the precheck again, and a vehicle put in AUTO while the operator looked away is
    not taken over; back in MANUAL, the experiment asks again."""
    sig = design_signal(sabertooth, "uvr", duration_s=10.0, seed=0)
    e = Excite(sabertooth, sig)
    out = _ready(e)
    assert e.phase is Phase.CONFIRM
    out += _ready(e, 6.0, "AUTO", ModeClass.AUTONOMOUS)
    out += e.step(Confirm())
    assert e.phase is Phase.PRECHECK and "cannot start: vehicle in AUTO" in e.reason
    out += _ready(e, 12.0) + _ready(e, 18.0)
    assert e.phase is Phase.CONFIRM
    assert not [o for o in out if isinstance(o, OpenLoop | Release)]


@pytest.mark.parametrize(("mode", "mode_class"), [
    ("AUTO", ModeClass.AUTONOMOUS), ("GUIDED", ModeClass.AUTONOMOUS),
    ("SURFACE", ModeClass.FAILSAFE), ("MOTOR_DETECT", ModeClass.SERVICE),
    ("MISSION", ModeClass.AUTONOMOUS),     # a vehicle's own word: its driver's class decides
])
def test_a_vehicle_on_its_own_plan_or_failsafe_is_not_taken_over(
        sabertooth: Profile, mode: str, mode_class: ModeClass) -> None:
    """The trim procedure's precheck (trimd.core.precheck): confirmed up front, the
    experiment still does not take a vehicle out of a mission or a failsafe, whatever
    the mode is called."""
    sig = design_signal(sabertooth, "uvr", duration_s=10.0, seed=0)
    e = Excite(sabertooth, sig, confirmed=True)
    out = _ready(e, 0.0, mode, mode_class)
    assert e.phase is Phase.PRECHECK and f"vehicle in {mode}" in e.reason
    for t in range(6, 42, 6):      # the vehicle stays in that mode past connect_timeout_s
        out += _ready(e, float(t), mode, mode_class)
    assert not [o for o in out if isinstance(o, OpenLoop | Release)]
    assert e.phase is Phase.FAILED and f"timeout: waiting: vehicle in {mode}" in e.reason


@pytest.mark.parametrize("event, cause", [
    (Attitude(5.0, math.radians(31.0), 0.0, 0.0, 0.0, 0.0, 0.0), "envelope"),
    (Depth(5.0, 16.0), "envelope"),
    (Health(5.0, False, "", False), "link"),
    (Health(5.0, True, "MANUAL", False), "vehicle"),           # disarmed
    (PilotInput(5.0, "sticks from another station"), "pilot"),
    (Tick(10.0), "link"),
    (Abort("stop"), "operator"),
])
def test_every_failure_releases(sabertooth: Profile, event: object, cause: str) -> None:
    sig = design_signal(sabertooth, "uwq", duration_s=60.0, seed=0)
    e = Excite(sabertooth, sig, confirmed=True, depth_excursion_m=5.0)
    _ready(e, 0.0)
    assert e.phase is Phase.COLLECT
    out = e.step(event)  # type: ignore[arg-type]
    assert e.phase.final and e.cause == cause
    assert isinstance(out[0], Release)


def test_completes_and_releases(sabertooth: Profile) -> None:
    sig = design_signal(sabertooth, "uvr", duration_s=2.0, seed=0)
    e = Excite(sabertooth, sig, confirmed=True)
    out = _ready(e)
    out += e.step(Attitude(10.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert e.phase is Phase.DONE
    assert any(isinstance(o, Release) for o in out)


def test_attitude_hold_only_where_the_thrusters_turn_the_vehicle(sabertooth: Profile,
                                                                 bluerov: Profile) -> None:
    # the Sabertooth's surge, sway and yaw thrusters sit level with its CG: open loop
    free = design_signal(sabertooth, "uvr", duration_s=60.0, seed=0)
    assert free.hold == ()
    assert all(d.amplitude == pytest.approx(0.6) for d in free.axes if d.axis != 5)
    # the BlueROV2 Heavy's horizontal thrusters sit below it: roll and pitch are held and
    # the coupled amplitudes lowered so that the hold keeps their moment in the allowance
    held = design_signal(bluerov, "uvr", duration_s=60.0, seed=0, hold_bandwidth_rad_s=4.0)
    assert {h.axis for h in held.hold} == {3, 4}
    forces = axis_forces(bluerov)
    prior = prior_values(bluerov)
    allowance = 0.25 * math.radians(bluerov.procedure.max_tilt_deg)
    for h in held.hold:
        assert h.bandwidth_rad_s <= 4.0
        J = prior[HYDRO_NAMES[h.axis]]
        moment = sum(abs(forces[h.axis, d.axis]) * d.amplitude for d in held.axes)
        assert 0.27 * moment / (J * h.bandwidth_rad_s ** 2) <= allowance * 1.001
    assert all(0.1 < d.amplitude < 0.6 for d in held.axes)


def test_the_hold_pushes_back_towards_level(bluerov: Profile) -> None:
    sig = design_signal(bluerov, "uvr", duration_s=60.0, seed=0)
    e = Excite(bluerov, sig, confirmed=True)
    _ready(e)
    assert e.phase is Phase.COLLECT
    out = e.step(Attitude(6.1, math.radians(5.0), math.radians(-5.0), 0.0, 0.0, 0.0, 0.0))
    cmd = [o for o in out if isinstance(o, OpenLoop)][-1]
    base = sig.at(6.1 - 5.0)
    assert cmd.axes[3] < base[3] and cmd.axes[4] > base[4]     # roll right → left, etc.
    assert cmd.axes[:3] == base[:3] and cmd.axes[5] == base[5]


def test_roll_and_pitch_doublets_ask_for_full_authority(sabertooth: Profile,
                                                        bluerov: Profile) -> None:
    """Whatever ``amplitude`` the velocity axes get, a tilt axis's doublets use what the
    hold and the tilt limit allow: all of it on the metacentrically stiff Sabertooth
    (which pitched too slowly for its gyro at 0.6), the hold's limit on the BlueROV2
    Heavy."""
    stiff = design_signal(sabertooth, "uvwpqr", duration_s=60.0, seed=0)
    assert {d.axis: d.amplitude for d in stiff.axes if d.axis in (3, 4)} == {3: 1.0, 4: 1.0}
    assert all(d.amplitude == pytest.approx(0.6) for d in stiff.axes if d.axis in (0, 1))
    held = design_signal(bluerov, "uvwpqr", duration_s=60.0, seed=0)
    assert all(d.amplitude < 0.2 for d in held.axes if d.axis in (3, 4))


def test_a_velocity_axis_is_driven_until_the_prior_reaches_the_target_speed(
        sabertooth: Profile, bluerov: Profile) -> None:
    """The Sabertooth's yaw damping holds it at 0.11 rad/s under 0.6 of its authority
    (close to its gyro's noise): its yaw asks for all of it; an axis that already reaches
    TARGET_SPEED keeps the asked amplitude, and the BlueROV2 Heavy's hold still lowers
    its coupled axes."""
    prior = prior_values(sabertooth)
    authority = axis_authority(sabertooth)[5]
    assert authority * 0.6 < (abs(prior["N_r"]) * TARGET_SPEED
                              + abs(prior["N_r|r|"]) * TARGET_SPEED ** 2)
    sig = design_signal(sabertooth, "uvr", duration_s=60.0, seed=0, amplitude=0.3)
    amplitude = {d.axis: d.amplitude for d in sig.axes}
    assert amplitude[5] == 1.0
    assert amplitude[0] == pytest.approx(0.3)   # surge: 1.3 m/s under 0.6
    assert max(abs(lv[5] - sig.offsets[5]) for lv in sig.levels) == pytest.approx(1.0)
    held = design_signal(bluerov, "uvr", duration_s=60.0, seed=0)
    assert all(d.amplitude < 0.6 for d in held.axes)


def test_commands_change_only_at_thruster_samples(bluerov: Profile) -> None:
    """Once the vehicle reports its thruster outputs, the hold's output goes out when a
    thruster sample arrives (from the latest attitude), never between two of them: the
    record the fit reads shows every command the vehicle acted on."""
    sig = design_signal(bluerov, "uvr", duration_s=60.0, seed=0)
    e = Excite(bluerov, sig, confirmed=True)
    _ready(e)
    pwm = tuple(1500.0 for _ in bluerov.thrusters)
    e.step(Thrusters(5.9, pwm))
    e.step(Thrusters(6.0, pwm))   # thruster outputs at 10 Hz
    tilted = Attitude(6.05, math.radians(5.0), math.radians(-5.0), 0.0, 0.0, 0.0, 0.0)
    assert not [o for o in e.step(tilted) if isinstance(o, OpenLoop)]
    cmd = [o for o in e.step(Thrusters(6.1, pwm)) if isinstance(o, OpenLoop)][-1]
    base = sig.at(6.1 - 5.0)
    assert cmd.axes[3] < base[3] and cmd.axes[4] > base[4]
    # thruster outputs at 4 Hz are too slow for the hold's loop: back to attitude samples
    e.step(Thrusters(6.35, pwm))
    again = Attitude(6.4, math.radians(8.0), math.radians(-8.0), 0.0, 0.0, 0.0, 0.0)
    assert [o for o in e.step(again) if isinstance(o, OpenLoop)]


def test_a_depth_hold_on_every_stage_slower_than_the_heave_doublets(
        sabertooth: Profile, bluerov: Profile) -> None:
    """Triple pole at −ω with the prior damping as the derivative term (module docstring);
    under heave doublets ω stays a fifth of their slowest frequency π/T_d, so the hold
    takes the drift (a buoyancy the prior does not know, heave from surge at a pitch) and
    leaves the doublets."""
    h = design_signal(sabertooth, "uvr", duration_s=60.0).depth_hold
    assert h is not None and h.axis == 2 and h.kd == 0.0
    prior = prior_values(sabertooth)
    M, D = sabertooth.mass_kg + prior["Z_wdot"], -prior["Z_w"]
    w = D / (3 * M)
    a = axis_forces(sabertooth)[2, 2]
    assert h.bandwidth_rad_s == pytest.approx(w)
    assert (h.kp * a, h.ki * a) == (pytest.approx(3 * M * w**2), pytest.approx(M * w**3))
    # closed loop M·s³ + D·s² + kp·s + ki: all three poles at −ω
    poles = np.roots([M, D, h.kp * a, h.ki * a])
    np.testing.assert_allclose(poles.real, -w, rtol=1e-3)
    for profile in (sabertooth, bluerov):
        for stage in ("uwq", "uvwpqr"):
            sig = design_signal(profile, stage, duration_s=60.0)
            heave = next(d for d in sig.axes if d.axis == 2)
            hold = sig.depth_hold
            assert hold is not None
            assert hold.bandwidth_rad_s <= 0.2 * math.pi / heave.hold_s[1] + 1e-12
            # stable: Routh–Hurwitz of M·s³ + D·s² + kp·s + ki on the prior
            pr = prior_values(profile)
            m, d = profile.mass_kg + pr["Z_wdot"], -pr["Z_w"]
            auth = axis_forces(profile)[2, 2]
            assert d * hold.kp * auth > m * hold.ki * auth > 0


def test_the_depth_hold_pushes_back_towards_the_start_depth(sabertooth: Profile) -> None:
    sig = design_signal(sabertooth, "uvr", duration_s=60.0, seed=0)
    e = Excite(sabertooth, sig, confirmed=True)
    _ready(e)
    assert e.phase is Phase.COLLECT
    base = sig.at(6.1 - 5.0)[2]
    heave = []
    for t, depth in ((6.0, 9.5), (6.2, 10.5)):  # above, then below the start depth, 10 m
        e.step(Depth(t, depth))
        out = e.step(Attitude(t + 0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
        heave.append([o for o in out if isinstance(o, OpenLoop)][-1].axes[2])
    assert heave[0] > base > heave[1]  # heave input is positive down


@pytest.mark.slow
def test_uvr_completes_within_the_default_depth_envelope(
        capsys: pytest.CaptureFixture[str]) -> None:
    """The Sabertooth's 58 N of buoyancy is an input inside the deadband: without the depth
    hold it rose 5 m in 79 s of the default 120 s experiment."""
    from trimd.cli.main import main

    assert main(["excite", "--link", "sim", "--profile", "sabertooth-dh2", "--stage", "uvr",
                 "--yes", "--no-record"]) == 0
    assert "excitation complete (120.0 s)" in capsys.readouterr().out
