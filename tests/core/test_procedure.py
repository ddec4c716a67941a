"""The trim procedure, driven by synthetic event sequences (no I/O, no clock)."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from itertools import pairwise

import numpy as np
import pytest

from tests.helpers import FakeVehicle, command_plan, payload_truth
from trimd.core.estimate import HoldSamples
from trimd.core.events import Abort, Confirm, Notice, Phase, Tick
from trimd.core.guards import ENVELOPE_MARGIN_DEG, STREAM_MISSED_PERIODS
from trimd.core.model import thrust_configuration
from trimd.core.procedure import HEADING_LEASH_DEG, MIN_RATES_HZ, Procedure
from trimd.core.profile import Profile
from trimd.core.samples import HoldAttitude, PilotInput, Release

DT = 0.01


def run(proc: Procedure, vehicle: FakeVehicle, t_end: float, *, t_start: float = 0.0,
        silent_after: float = math.inf,
        at: dict[float, Callable[[], object]] | None = None,
        tick_lead: Callable[[], float] = lambda: 0.0) -> list[tuple[float, object]]:
    """Feed the vehicle's samples and Ticks to ``proc``; apply its commands; log outputs.
    Each Tick runs ``tick_lead()`` seconds ahead of the samples (a live shell whose event
    loop is late: its Tick is the last sample's time plus the wall time since)."""
    log: list[tuple[float, object]] = []
    pending = dict(at or {})
    t = t_start
    while t < t_end and not proc.phase.final:
        t = round(t + DT, 6)
        events: list[object] = [] if t > silent_after else vehicle.samples(t, DT)
        for when in [w for w in pending if w <= t]:
            events.append(pending.pop(when)())
        events.append(Tick(t + tick_lead()))
        for e in events:
            for out in proc.step(e):  # type: ignore[arg-type]
                log.append((t, out))
                if not isinstance(out, Notice):
                    vehicle.apply(t, out)
    return log


@pytest.fixture
def thesis_vehicle(sabertooth: Profile) -> FakeVehicle:
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    return FakeVehicle(sabertooth, W, r_g)


def test_full_procedure_estimates_the_payload(sabertooth: Profile,
                                              thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth, confirmed=True, propose=lambda est: "proposal")
    log = run(proc, thesis_vehicle, 1000.0)
    assert proc.phase is Phase.DONE, proc.reason
    est = proc.estimate
    assert est is not None and proc.proposal == "proposal"
    assert abs(est.m_ext_kg - 10.0) < max(4 * est.m_ext_std_kg, 0.05)
    np.testing.assert_allclose(est.r_g_m, thesis_vehicle.r_g, atol=5e-4)
    sent = [c for _, c in thesis_vehicle.commands]
    assert command_plan(sent) == [(0.0, 0.0), (20.0, 20.0), "release"]
    holds = [c for c in sent if isinstance(c, HoldAttitude)]
    assert all(abs(math.degrees(h.phi)) <= sabertooth.procedure.max_tilt_deg for h in holds)
    assert isinstance(thesis_vehicle.commands[-1][1], Release)
    assert [n.kind for _, n in log if isinstance(n, Notice)][-1] == "result"
    assert len(est.holds) == 2 and all(h.samples > 100 for h in est.holds)


def test_late_ticks_change_nothing_the_samples_decide(sabertooth: Profile) -> None:
    """A replay has no Ticks; a live shell under load sends Ticks that run ahead of the
    samples by a varying amount. Phases begin, holds collect and end on the samples' own
    time, so both see the same holds, sample for sample."""
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    rng = np.random.default_rng(5)
    estimates = []
    for lead in (lambda: 0.0, lambda: float(rng.uniform(0.0, 0.3))):
        proc = Procedure(sabertooth, confirmed=True, propose=lambda est: None)
        run(proc, FakeVehicle(sabertooth, W, r_g), 1000.0, tick_lead=lead)
        assert proc.phase is Phase.DONE, proc.reason
        estimates.append(proc.estimate)
    on_time, late = estimates
    assert on_time is not None and late is not None
    assert [h.samples for h in late.holds] == [h.samples for h in on_time.holds]
    assert late.m_ext_kg == on_time.m_ext_kg


def test_holds_carry_each_thrusters_thrust(sabertooth: Profile,
                                           thesis_vehicle: FakeVehicle) -> None:
    """The estimate's ± needs each thruster's thrust per sample (the thrust curves'
    uncertainty); it is the thrust that makes the hold's τ."""
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 1000.0)
    holds = proc.hold_samples()
    T = thrust_configuration(sabertooth.thrusters)
    assert len(holds) == 2
    for h in holds:
        assert h.thrust is not None and h.thrust.shape == (len(h.t_s), len(sabertooth.thrusters))
        np.testing.assert_allclose(h.thrust @ T.T, h.tau, atol=1e-9)


def test_no_command_before_confirmation(sabertooth: Profile,
                                        thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth)
    run(proc, thesis_vehicle, 60.0)
    assert proc.phase is Phase.CONFIRM and thesis_vehicle.commands == []
    run(proc, thesis_vehicle, 62.0, t_start=60.0, at={60.5: Confirm})
    assert proc.phase is Phase.SETTLE
    assert isinstance(thesis_vehicle.commands[0][1], HoldAttitude)


def hold_times(commands: list[tuple[float, object]]) -> list[tuple[float, float]]:
    """Per hold of the plan (:func:`tests.helpers.command_plan`), when the ramp to it
    started and when the command reached it [s]."""
    holds = [c for _, c in commands if isinstance(c, HoldAttitude)]
    t = [t for t, c in commands if isinstance(c, HoldAttitude)]
    steps = command_plan(holds)                       # each hold once
    sent = [command_plan([c])[0] for c in holds]      # each command as a plan step
    times, k = [], 0
    for target in steps:
        start = t[k]
        k = sent.index(target, k)
        times.append((start, t[k]))
        while k + 1 < len(sent) and sent[k + 1] == target:
            k += 1
    return times


def released_within(vehicle: FakeVehicle, t_cause: float, limit_s: float) -> bool:
    releases = [t for t, c in vehicle.commands if isinstance(c, Release)]
    return len(releases) == 1 and t_cause <= releases[0] <= t_cause + limit_s


def release_times(vehicle: FakeVehicle) -> list[float]:
    return [t for t, c in vehicle.commands if isinstance(c, Release)]


def test_link_silence_mid_hold_sends_the_release_within_a_second_of_the_last_telemetry(
        sabertooth: Profile, thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 1000.0, silent_after=40.0)
    assert proc.phase is Phase.FAILED and "link lost: no telemetry" in proc.reason
    assert proc.cause == "link"
    last = max(thesis_vehicle.last_sent.values())
    [t_release] = release_times(thesis_vehicle)
    # not before link_timeout_s of silence, and within a second of the last sample
    assert last + sabertooth.procedure.link_timeout_s < t_release <= last + 1.0


def test_hold_that_never_settles_times_out(sabertooth: Profile,
                                           thesis_vehicle: FakeVehicle) -> None:
    thesis_vehicle.stuck_at_deg = 12.0
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 2000.0)
    assert proc.phase is Phase.FAILED
    assert "never settled" in proc.reason and "12.0°" in proc.reason
    assert isinstance(thesis_vehicle.commands[-1][1], Release)


def test_operator_abort_releases_at_once(sabertooth: Profile,
                                         thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 100.0, at={30.0: Abort})
    assert proc.phase is Phase.ABORTED and "operator" in proc.reason
    assert released_within(thesis_vehicle, 30.0, DT)


def test_an_abort_before_any_sample_is_stamped_at_session_time_zero(
        sabertooth: Profile) -> None:
    proc = Procedure(sabertooth)
    [notice] = proc.step(Abort("stopped by SIGTERM"))
    assert isinstance(notice, Notice) and notice.t_s == 0.0 and proc.progress.t_s == 0.0
    assert proc.phase is Phase.ABORTED


def test_depth_excursion_aborts(sabertooth: Profile, thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 8.0)  # through precheck with a steady depth
    thesis_vehicle.depth_drift_m_s = 0.1
    run(proc, thesis_vehicle, 200.0, t_start=8.0)
    assert proc.phase is Phase.FAILED and "depth excursion" in proc.reason
    assert isinstance(thesis_vehicle.commands[-1][1], Release)


def test_disarmed_vehicle_is_reported_and_never_commanded(sabertooth: Profile,
                                                          thesis_vehicle: FakeVehicle) -> None:
    thesis_vehicle.armed = False
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 100.0)
    assert proc.phase is Phase.FAILED and "disarmed" in proc.reason
    assert thesis_vehicle.commands == []


def test_slow_telemetry_fails_precheck(sabertooth: Profile, thesis_vehicle: FakeVehicle) -> None:
    thesis_vehicle.rates_hz["thrusters"] = 1.0
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 100.0)
    assert proc.phase is Phase.FAILED and "thrusters at 1.0 Hz" in proc.reason


def test_internal_error_still_releases(sabertooth: Profile, bluerov: Profile,
                                       thesis_vehicle: FakeVehicle) -> None:
    """Thruster outputs that do not match the profile (8 for 6) must not leave the
    vehicle commanded."""
    W, r_g = payload_truth(bluerov, 0.2, np.zeros(3))
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 8.0)
    wrong = FakeVehicle(bluerov, W, r_g)
    run(proc, wrong, 50.0, t_start=8.0)
    assert proc.phase is Phase.FAILED and "internal error" in proc.reason
    assert isinstance(wrong.commands[-1][1], Release)


def test_progress_reports_phase_and_time_left(sabertooth: Profile,
                                              thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 12.0)
    p = proc.progress
    assert p.phase is Phase.SETTLE and p.holds == 2 and p.setpoint_deg == (0.0, 0.0)
    assert 0 < p.time_left_s <= sabertooth.procedure.settle_timeout_s
    assert 0.0 <= p.settled_fraction <= 1.0


def test_disarm_mid_hold_fails_and_releases(sabertooth: Profile,
                                            thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 20.0)
    assert proc.phase in (Phase.SETTLE, Phase.COLLECT)
    thesis_vehicle.armed = False
    run(proc, thesis_vehicle, 40.0, t_start=20.0)
    assert proc.phase is Phase.FAILED and "disarmed while trimd commanded it" in proc.reason
    assert proc.cause == "vehicle"
    # the next heartbeat (1 Hz) says so: released at once, nothing used
    assert released_within(thesis_vehicle, 20.0, 1.0 / thesis_vehicle.rates_hz["health"])
    assert isinstance(thesis_vehicle.commands[-1][1], Release) and proc.estimate is None


@pytest.mark.parametrize("stream", ["attitude", "thrusters", "depth"])
def test_a_stream_that_stops_mid_hold_releases_after_its_missed_periods(
        sabertooth: Profile, thesis_vehicle: FakeVehicle, stream: str) -> None:
    """Heartbeats go on, but trimd must not keep commanding without seeing the vehicle; a
    stream is lost after link_timeout_s or STREAM_MISSED_PERIODS of its slowest allowed
    rate, whichever is longer (a 1 Hz depth stream is not lost after 0.8 s)."""
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 35.0)
    assert proc.phase in (Phase.SETTLE, Phase.COLLECT)
    thesis_vehicle.muted.add(stream)
    run(proc, thesis_vehicle, 2000.0, t_start=35.0)
    assert proc.phase is Phase.FAILED and f"no {stream} for" in proc.reason
    assert proc.cause == "link"
    limit = max(sabertooth.procedure.link_timeout_s,
                STREAM_MISSED_PERIODS / MIN_RATES_HZ[stream])
    [t_release] = release_times(thesis_vehicle)
    assert limit < t_release - thesis_vehicle.last_sent[stream] <= limit + DT + 1e-9


def test_attitude_beyond_the_tilt_envelope_mid_hold_releases(
        sabertooth: Profile, thesis_vehicle: FakeVehicle) -> None:
    limit_deg = sabertooth.procedure.max_tilt_deg + ENVELOPE_MARGIN_DEG
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 30.0)
    thesis_vehicle.phi = math.radians(limit_deg - 1.0)   # a gust, still inside
    run(proc, thesis_vehicle, 31.0, t_start=30.0)
    assert proc.phase in (Phase.SETTLE, Phase.COLLECT) and release_times(thesis_vehicle) == []
    thesis_vehicle.phi = math.radians(limit_deg + 2.0)   # beyond it
    run(proc, thesis_vehicle, 40.0, t_start=31.0)
    assert proc.phase is Phase.FAILED and proc.cause == "envelope"
    said = re.fullmatch(r"attitude out of envelope: roll ([\d.]+)°, pitch \S+° \(limit (\d+)°\)",
                        proc.reason)
    assert said is not None, proc.reason
    assert float(said[1]) > limit_deg and float(said[2]) == limit_deg
    # the next attitude sample (20 Hz) shows it: released at once
    assert released_within(thesis_vehicle, 31.0, 1.0 / thesis_vehicle.rates_hz["attitude"])
    assert proc.estimate is None


def _run_to_collect_of_last_hold(proc: Procedure, vehicle: FakeVehicle) -> float:
    t = 0.0
    while not (proc.phase is Phase.COLLECT and proc.progress.hold == proc.progress.holds - 1):
        assert not proc.phase.final and t < 1000.0, proc.reason
        run(proc, vehicle, t + 1.0, t_start=t)
        t += 1.0
    return t


@pytest.mark.parametrize("when", ["settling the first hold", "collecting the last hold"])
def test_pilot_taking_over_mid_hold_releases_at_once_and_no_estimate_is_made(
        sabertooth: Profile, thesis_vehicle: FakeVehicle, when: str) -> None:
    proc = Procedure(sabertooth, confirmed=True, propose=lambda est: "proposal")
    if when.startswith("settling"):
        t = 20.0
        run(proc, thesis_vehicle, t)
        assert proc.phase is Phase.SETTLE and proc.progress.hold == 0
    else:
        t = _run_to_collect_of_last_hold(proc, thesis_vehicle)
    takeover = PilotInput(t + 0.5, "mode changed to MANUAL by another station")
    log = run(proc, thesis_vehicle, 1000.0, t_start=t, at={t + 0.5: lambda: takeover})
    assert proc.phase is Phase.FAILED and proc.cause == "pilot"
    assert proc.reason == ("the pilot took over (mode changed to MANUAL by another "
                           "station): trimd released control")
    assert released_within(thesis_vehicle, t + 0.5, DT)
    assert isinstance(thesis_vehicle.commands[-1][1], Release)   # nothing after it
    assert proc.estimate is None and proc.proposal is None
    assert "result" not in [n.kind for _, n in log if isinstance(n, Notice)]


def test_pilot_input_before_commanding_is_no_reason_to_stop(
        sabertooth: Profile, thesis_vehicle: FakeVehicle) -> None:
    """Before trimd commands, the pilot flies: that is no takeover."""
    proc = Procedure(sabertooth)
    run(proc, thesis_vehicle, 20.0, at={3.0: lambda: PilotInput(3.0, "sticks")})
    assert proc.phase is Phase.CONFIRM and thesis_vehicle.commands == []


def test_each_hold_uses_only_its_own_steady_samples(sabertooth: Profile,
                                                   thesis_vehicle: FakeVehicle) -> None:
    """Nothing from before a hold was commanded and had settled for min_steady_s, and
    nothing from after the next command, enters the estimate."""
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 1000.0)
    assert proc.phase is Phase.DONE and proc.estimate is not None
    t_cmd = hold_times(thesis_vehicle.commands)
    ends = [*(ramp for ramp, _ in t_cmd[1:]), release_times(thesis_vehicle)[0]]
    for hold, (_, start), end in zip(proc.estimate.holds, t_cmd, ends, strict=True):
        assert start + sabertooth.procedure.min_steady_s <= hold.t_start_s
        assert hold.t_end_s <= end


@pytest.mark.parametrize(("change", "expected"), [
    ({"mode": "AUTO"}, "vehicle in AUTO (autonomous): switch it to a mode the pilot flies"),
    ({"mode": "SURFACE"}, "vehicle in SURFACE (failsafe): switch it"),
    ({"depth_drift_m_s": 0.2}, "depth not steady: 1.0"),
])
def test_precheck_refuses_a_busy_or_moving_vehicle(
        sabertooth: Profile, thesis_vehicle: FakeVehicle, change: dict[str, object],
        expected: str) -> None:
    for key, value in change.items():
        setattr(thesis_vehicle, key, value)
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, thesis_vehicle, 100.0)
    assert proc.phase is Phase.FAILED and expected in proc.reason
    assert thesis_vehicle.commands == []


def test_confirm_checks_the_vehicle_again(sabertooth: Profile,
                                          thesis_vehicle: FakeVehicle) -> None:
    proc = Procedure(sabertooth)
    run(proc, thesis_vehicle, 20.0)
    assert proc.phase is Phase.CONFIRM
    thesis_vehicle.armed = False         # while the operator looked away
    run(proc, thesis_vehicle, 22.0, t_start=20.0, at={21.5: Confirm})
    assert proc.phase is Phase.PRECHECK and "cannot start: vehicle disarmed" in proc.reason
    thesis_vehicle.armed = True
    run(proc, thesis_vehicle, 40.0, t_start=22.0)
    assert proc.phase is Phase.CONFIRM and thesis_vehicle.commands == []  # asks again


def test_the_held_heading_follows_a_turning_vehicle_on_a_leash(sabertooth: Profile) -> None:
    """A hold commands roll and pitch; the heading it holds trails the vehicle's own by at
    most HEADING_LEASH_DEG (an absolute heading held at a tilt limit-cycles through the
    roll and pitch loops), moved in steps of half the leash, never with another tilt."""
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    vehicle = FakeVehicle(sabertooth, W, r_g, yaw_rate_rad_s=math.radians(1.0))
    proc = Procedure(sabertooth, confirmed=True, propose=lambda est: "proposal")
    log = run(proc, vehicle, 1000.0)
    assert proc.phase is Phase.DONE, proc.reason
    holds = [(t, c) for t, c in log if isinstance(c, HoldAttitude)]
    turned_deg = math.degrees(vehicle.yaw_rate_rad_s) * (holds[-1][0] - holds[0][0])
    moves = sum(c.psi != before.psi for (_, before), (_, c) in pairwise(holds))
    assert moves == pytest.approx(turned_deg / (HEADING_LEASH_DEG / 2), abs=2)
    for t, c in holds[1:]:
        heading = 0.3 + vehicle.yaw_rate_rad_s * t
        assert abs(math.degrees(c.psi - heading)) <= HEADING_LEASH_DEG
        assert all(-0.01 <= round(math.degrees(a), 2) <= 20 for a in (c.phi, c.theta))


def test_a_calibration_hold_collects_its_whole_time(sabertooth: Profile,
                                                    thesis_vehicle: FakeVehicle) -> None:
    """A verify hold ends once its rows are known (the stop rule's first look, 10 s here);
    with ``collect_s`` (a calibration's level hold) it collects that long, whatever the
    stop rule says, and ends without the "not reached" warning."""
    spans = {}
    for collect_s in (None, 60.0):
        proc = Procedure(sabertooth, confirmed=True, verify=lambda hold: hold,
                         collect_s=collect_s)
        log = run(proc, FakeVehicle(sabertooth, thesis_vehicle.W, thesis_vehicle.r_g), 1000.0)
        assert proc.phase is Phase.DONE, proc.reason
        hold = proc.verification
        assert isinstance(hold, HoldSamples)
        spans[collect_s] = float(hold.t_s[-1] - hold.t_s[0])
        assert not any(isinstance(n, Notice) and n.kind == "warning" for _, n in log)
    assert spans[None] < 20.0 and 59.0 <= spans[60.0] <= 61.0, spans
