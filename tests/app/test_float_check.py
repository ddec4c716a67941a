"""The float check on the simulated vehicle (``trimd float``, docs/method.md §8).

Physics, not shapes: let go with every thruster at neutral, the simulated vehicle that its
profile does not describe exactly (``truth=perturbed``) under realistic disturbances
(``disturb=real``) must float at its TRUE passive trim
(:func:`trimd.drivers.sim.truth.passive_trim_deg` of its true net weight and moments), and
the float check must find it within its 95 % interval and within 0.2°; its recording must
replay to the very same result; a vehicle that sinks out of the depth envelope, an abort,
a missing confirmation must each leave it released or never commanded.
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import subprocess
from collections.abc import AsyncIterator
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pytest

from tests.app.test_correction import assert_levels_as_said, true_trim_deg
from tests.drivers.test_mavlink_link import TRIMD, free_udp_port, wait_bound
from tests.helpers import REPO, ballast_payload, sim_trim
from trimd.app.apply import apply_ballast
from trimd.app.connect import open_link
from trimd.app.float_check import (
    FloatRequest,
    float_correction,
    float_from_settings,
    float_session,
    float_settings,
    store_float_check,
)
from trimd.app.history import History
from trimd.app.replay import replay_profile, replay_session
from trimd.app.session import SessionResult
from trimd.app.verify import VerifyTarget, trim_target
from trimd.ballast.changes import change_loads
from trimd.ballast.correct import propose_float_correction
from trimd.ballast.proposal import Proposal, proposal_to_dict
from trimd.cli.main import main
from trimd.core.errors import DataError
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.events import Cause, Notice, Output, Phase, Progress
from trimd.core.float_check import NEUTRAL, FloatCheck
from trimd.core.floating import Z95, FloatResult, Verdict
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Command, Release, Sample
from trimd.drivers.sim.config import parse_sim_options
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.truth import passive_trim_deg
from trimd.drivers.sim.vehicle import SimVehicle
from trimd.logs.recorder import TlogRecorder
from trimd.logs.replay import recorded_float_check

OPTIONS = "disturb=real,truth=perturbed"


@dataclass
class Watched:
    """A simulated link that keeps what trimd sent and the largest thrust moment [N·m]
    the simulated thrusters gave while the vehicle floated."""

    link: SimLink
    sent: list[Command] = field(default_factory=list)
    t_float: float = math.nan
    moment_Nm: float = 0.0
    force_N: float = 0.0
    #: the thrust counts from this long [s] after letting go (the thrusters' spin-down)
    after_s: float = 2.0

    @property
    def description(self) -> str:
        return self.link.description

    async def samples(self) -> AsyncIterator[Sample]:
        async for s in self.link.samples():
            if self.link.vehicle.t_s - self.t_float >= self.after_s:
                tau = self.link.vehicle.truth.tau
                self.force_N = max(self.force_N, float(np.abs(tau[:3]).max()))
                self.moment_Nm = max(self.moment_Nm, float(np.abs(tau[3:5]).max()))
            yield s

    async def send(self, command: Command) -> None:
        self.sent.append(command)
        await self.link.send(command)
        self.t_float = self.link.vehicle.t_s if command == NEUTRAL else math.nan

    async def close(self) -> None:
        await self.link.close()


@dataclass
class Float:
    """One float check on the simulator: the session's result, the link, the true trim."""

    result: SessionResult
    watched: Watched
    truth_deg: tuple[float, float]
    check: FloatCheck

    @property
    def r(self) -> FloatResult:
        assert isinstance(self.result.verification, FloatResult), self.result.reason
        return self.result.verification


class AbortAfter:
    """Aborts the session ``after_s`` of sample time into the float (or at confirm)."""

    def __init__(self, after_s: float | None = None) -> None:
        self.after_s = after_s
        self.t_float = math.nan
        self.abort = lambda reason: None

    def output(self, out: Output, progress: Progress) -> None:
        if isinstance(out, Notice) and out.phase is Phase.CONFIRM and self.after_s is None:
            self.abort("not confirmed by the operator")
        if isinstance(out, Notice) and out.phase is Phase.SETTLE:
            self.t_float = out.t_s

    def sample(self, sample: Sample, progress: Progress) -> None:
        if self.after_s is not None and sample.t_s - self.t_float >= self.after_s:
            self.abort("aborted by the operator")


def float_on_sim(profile: Profile, payload: str, seed: int, *, options: str = OPTIONS,
                 depth_excursion_m: float | None = None, record: Path | None = None,
                 confirmed: bool = True, stop: AbortAfter | None = None) -> Float:
    async def go() -> Float:
        url = f"sim:payload={payload},seed={seed}" + (f",{options}" if options else "")
        link = await open_link(url, profile)
        assert isinstance(link, SimLink)
        watched = Watched(link)
        session = float_session(watched, profile, [stop] if stop else [], FloatRequest(
            str(profile.source), confirmed=confirmed, depth_excursion_m=depth_excursion_m,
            record=record), wall_clock=False)
        if stop is not None:
            stop.abort = session.abort
        result = await session.run()
        trim = passive_trim_deg(link.vehicle.truth.mass.net)
        assert isinstance(session.procedure, FloatCheck)
        return Float(result, watched, trim, session.procedure)
    return asyncio.run(go())


def assert_true_trim(f: Float) -> None:
    """The float attitude is the true passive trim within its 95 % interval and 0.2°."""
    r = f.r
    for got, std, want in ((r.roll_deg, r.roll_std_deg, f.truth_deg[0]),
                           (r.pitch_deg, r.pitch_std_deg, f.truth_deg[1])):
        assert abs(got - want) <= Z95 * std, (got, want, std, r)
        assert abs(got - want) <= 0.2, (got, want, r)


def assert_replays_exactly(log: Path, live: FloatResult) -> None:
    replayed, _ = asyncio.run(replay_session(str(log), replay_profile(str(log), None)[0],
                                             speed=None, presenters=[], method="milp"))
    assert replayed.verification == live   # every float, bit for bit


@pytest.mark.parametrize(("name", "payload", "seed", "excursion_m"), [
    ("bluerov2-heavy", "0.4@W-aft-stbd", 5, None),
    ("bluerov2-heavy", "0.4@W-aft-stbd", 8, None),
    ("sabertooth-dh2", "10@AftSB", 5, 30.0)])
def test_the_float_is_the_true_passive_trim(name: str, payload: str, seed: int,
                                            excursion_m: float | None, tmp_path: Path,
                                            bluerov: Profile, sabertooth: Profile) -> None:
    """Raw payloads, far out of trim (5–14°): the Heavy settles in seconds within its
    0.5 m envelope; the Sabertooth's pitch relaxes in ≈ 21 s and it rises 0.1 m/s, so it
    needs room (30 m here, from 30 m down: the simulator has no surface, and a depth
    above −10 m is no depth reading to trimd's MAVLink decoder). Recorded, and replayed to
    the same result."""
    profile = bluerov if name == "bluerov2-heavy" else sabertooth
    log = tmp_path / "float.tlog"
    start = f",depth_m={excursion_m:g}" if excursion_m else ""
    f = float_on_sim(profile, payload, seed, options=OPTIONS + start,
                     depth_excursion_m=excursion_m, record=log)
    assert f.result.phase is Phase.DONE, f.result.reason
    assert_true_trim(f)
    assert f.r.verdict is Verdict.NOT_LEVEL
    assert f.watched.sent == [NEUTRAL, Release()]
    assert_replays_exactly(log, f.r)


@pytest.mark.parametrize(("name", "payload", "seed", "excursion_m"), [
    ("bluerov2-heavy", "0.4@W-aft-stbd", 0, 2.0), ("sabertooth-dh2", "10@AftSB", 3, 10.0)])
def test_after_ballast_the_float_finds_what_the_ballast_left(
        name: str, payload: str, seed: int, excursion_m: float, bluerov: Profile,
        sabertooth: Profile) -> None:
    """The use case: trim, fit the proposal's ballast, float. What the ballast left (1.6°
    of roll on this Heavy, 1.7° of pitch on this Sabertooth: trims whose thrust map near
    the dead band misled them) is found to 0.2°, with a ± (0.2–0.3° at 95 %) well inside
    the level tolerance of the Heavy and near the Sabertooth's."""
    profile = bluerov if name == "bluerov2-heavy" else sabertooth
    trim = sim_trim(profile, payload, seed, OPTIONS)
    assert isinstance(trim.result.proposal, Proposal), trim.result.reason
    ballasted = f"{payload}+{ballast_payload(trim.result.proposal, profile)}"
    f = float_on_sim(profile, ballasted, seed, depth_excursion_m=excursion_m)
    assert f.result.phase is Phase.DONE, f.result.reason
    assert f.truth_deg == pytest.approx(trim.trim_after_proposal_deg(), abs=1e-9)
    assert_true_trim(f)
    assert max(f.r.roll_std_deg, f.r.pitch_std_deg) * Z95 < 0.35


def test_neutral_input_gives_no_thrust(bluerov: Profile, sabertooth: Profile) -> None:
    """Open loop at zero: PWM at neutral, inside every dead band, so no thrust at all
    without the simulated PWM dither; with it (disturb=real, ±0.5 µs, an ESC hunting at
    its band edge) a few hundredths of a degree of trim at most. (The thrusters spin down
    from the hold's thrust with their lag, 0.1 s: counted from 2 s on.)"""
    f = float_on_sim(bluerov, "0.4@W-aft-stbd", 5, options="", depth_excursion_m=2.0)
    assert f.result.phase is Phase.DONE, f.result.reason
    assert f.watched.moment_Nm < 1e-6 and f.watched.force_N < 1e-6
    for profile, payload, seed, excursion in ((bluerov, "0.4@W-aft-stbd", 5, None),
                                              (sabertooth, "10@AftSB", 5, 30.0)):
        f = float_on_sim(profile, payload, seed, depth_excursion_m=excursion)
        stiffness = -profile.buoyancy_N * profile.r_b_m[2]
        assert math.degrees(f.watched.moment_Nm / stiffness) < 0.05


def test_a_sinking_vehicle_is_released_before_the_envelope(bluerov: Profile) -> None:
    """3 N heavy in water (seed 2), the Heavy sinks 0.07 m/s: at 80 % of its 0.5 m
    envelope it has not settled; released, failed, saying why."""
    f = float_on_sim(bluerov, "0.4@W-aft-stbd", 2)
    assert f.result.phase is Phase.FAILED and f.result.cause is Cause.ENVELOPE
    assert "sinks" in f.result.reason and "W − B > 0" in f.result.reason
    assert f.watched.sent == [NEUTRAL, Release()]
    depth = f.watched.link.vehicle.truth.eta[2] - f.check.start_depth_m
    assert 0.35 < depth < bluerov.procedure.max_depth_excursion_m
    assert f.watched.link.vehicle.mode == "ALT_HOLD"   # back in the pilot's depth hold


def test_an_abort_releases_at_once(bluerov: Profile) -> None:
    stop = AbortAfter(3.0)
    f = float_on_sim(bluerov, "0.4@W-aft-stbd", 5, stop=stop)
    assert f.result.phase is Phase.ABORTED and f.watched.sent == [NEUTRAL, Release()]
    assert f.watched.link.vehicle.mode == "ALT_HOLD"


def test_nothing_is_commanded_without_confirmation(bluerov: Profile) -> None:
    f = float_on_sim(bluerov, "0.4@W-aft-stbd", 5, confirmed=False, stop=AbortAfter())
    assert f.result.phase is Phase.ABORTED and f.watched.sent == []
    assert f.watched.link.vehicle.mode == "ALT_HOLD"


def test_trimd_float_prints_the_verdict_and_replays(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]
                                                    ) -> None:
    """``trimd float``: exit 0 for a level vehicle (the Heavy as its profile says, no
    payload), 1 for one that is not; the last JSON line is the float; ``trimd replay``
    of the recording prints the same line."""
    log = tmp_path / "level.tlog"
    code = main(["float", "--link", "sim:seed=1,disturb=real", "--profile", "bluerov2-heavy",
                 "--yes", "--json", "--max-depth-excursion", "2", "--record", str(log)])
    live = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert code == 0 and live["type"] == "float" and live["verdict"] == "level", live
    assert main(["history", "--json"]) == 0  # stored in the history ($TRIMD_DATA_DIR)
    (stored,) = json.loads(capsys.readouterr().out)["vehicles"][0]["float_checks"]
    assert stored["pitch_deg"] == live["pitch_deg"] and stored["log_path"] == str(log)
    assert abs(live["roll_deg"]) < 0.2 and abs(live["pitch_deg"]) < 0.2
    assert main(["replay", str(log), "--headless", "--json"]) == 0
    assert json.loads(capsys.readouterr().out.splitlines()[-1]) == live
    code = main(["float", "--link", f"sim:payload=0.4@W-aft-stbd,seed=5,{OPTIONS}",
                 "--profile", "bluerov2-heavy", "--yes", "--no-record"])
    out = capsys.readouterr().out
    assert code == 1 and "NOT level within 1°" in out


def test_only_a_float_check_s_recording_replays_as_one(bluerov: Profile, tmp_path: Path
                                                      ) -> None:
    """The settings block makes a recording a float check's; a malformed one is named."""
    plain, floated = tmp_path / "trim.tlog", tmp_path / "float.tlog"
    TlogRecorder(plain, bluerov, "").close()
    TlogRecorder(floated, bluerov, "", float_check={"depth_excursion_m": 1.5}).close()
    assert recorded_float_check(plain) is None
    assert recorded_float_check(floated) == {"depth_excursion_m": 1.5}
    check = float_from_settings(bluerov, {"depth_excursion_m": 1.5}, "x")
    assert check.depth_excursion_m == 1.5 and check.guard.depth_excursion_m == 1.5
    assert not check.for_correction       # recorded before the setting existed
    correcting = FloatCheck(bluerov, depth_excursion_m=2.0, for_correction=True)
    again = float_from_settings(bluerov, float_settings(correcting), "x")
    assert again.for_correction and again.depth_excursion_m == 2.0
    for bad in ({"depth_excursion_m": -1}, {"depth_excursion_m": 1.5, "for_correction": 1}):
        with pytest.raises(DataError, match="x: the recorded float check is malformed"):
            float_from_settings(bluerov, bad, "x")


def test_trimd_float_correct_from_the_command_line_records_and_replays(
        tmp_path: Path, bluerov: Profile, capsys: pytest.CaptureFixture[str]) -> None:
    """The operator's loop in the shell: ``trimd run`` (stored in the history), ``trimd
    ballast apply``, ``trimd float --correct``. The Heavy floats NOT level with the trim's
    ballast on and a 50 g piece the record does not know at W-front-port (the pilot left
    it there: whether the trim's ballast alone leaves a seed level is the benches' to
    measure), so the float collects to the end of its window and ends with the
    correction; its recording says it was for a correction and replays to the same float."""
    link = f"sim:payload=0.4@W-aft-stbd{{}},seed=3,{OPTIONS}"
    assert main(["run", "--link", link.format(""), "--profile", "bluerov2-heavy",
                 "--headless", "--yes", "--json", "--no-record"]) == 0
    trim = tmp_path / "trim.json"
    trim.write_text(capsys.readouterr().out.splitlines()[-1])
    assert main(["ballast", "apply", "--profile", "bluerov2-heavy", "--estimate",
                 str(trim)]) == 0
    proposal = json.loads(trim.read_text())["proposal"]
    log = tmp_path / "float.tlog"
    capsys.readouterr()
    left = "+0.05@W-front-port"
    code = main(["float", "--link", link.format(f"+{ballast_payload(proposal, bluerov)}{left}"),
                 "--profile", "bluerov2-heavy", "--yes", "--json",
                 "--max-depth-excursion", "2", "--record", str(log), "--correct"])
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    floated = next(x for x in lines if x["type"] == "float")
    assert code == 1 and floated["verdict"] == "not level", floated
    assert lines[-1]["type"] == "correction"
    assert recorded_float_check(log) == {"depth_excursion_m": 2.0, "for_correction": True}
    # collected to the end: the depth envelope or collect_max_s, not the verdict
    assert ("depth" in floated["stopped"]
            or floated["t_end_s"] - floated["t_start_s"] >= bluerov.procedure.collect_max_s)
    assert main(["replay", str(log), "--headless", "--json"]) == 0   # a result: DONE
    replayed = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert next(x for x in replayed if x["type"] == "float") == floated


@pytest.mark.slow
def test_trimd_float_over_mavlink_against_the_served_simulator(tmp_path: Path) -> None:
    """``trimd float`` over MAVLink against ``trimd sim --serve`` (ArduSub's MANUAL with
    neutral sticks, the mode restored on release): the served vehicle's true trim within
    3σ of the float's (one run whose stream the machine times, not a seeded one: a 95 %
    bound would fail one run in ten by itself; 0.20-0.21° = 2σ seen under heavy load;
    bench_float measures the coverage), and the packets as recorded replay to the same
    line. At
    twice real time: faster, a loaded machine delays the attitude stream past the guard's
    link timeout."""
    payload, seed = "0.4@W-aft-stbd", 5
    log, port = tmp_path / "float.tlog", free_udp_port()
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.Popen(
        [*TRIMD, "float", "--link", f"mavlink:udpin:127.0.0.1:{port}?pilot=always",
         "--profile", "bluerov2-heavy", "--yes", "--json", "--record", str(log)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)
    wait_bound(port, run)
    sim = subprocess.Popen(
        [*TRIMD, "sim", "--profile", "bluerov2-heavy", "--payload", payload, "--seed",
         str(seed), "--serve", f"mavlink:udpout:127.0.0.1:{port}", "--rate", "2",
         "--options", f"{OPTIONS},armed=true,mode=ALT_HOLD"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)
    try:
        out, err = run.communicate(timeout=150)
    finally:
        sim.kill()
        sim.wait()
    assert run.returncode == 1, err                       # not level: 9° and 7° off
    line = json.loads(out.splitlines()[-1])
    assert line["type"] == "float", line
    vehicle = SimVehicle(load_profile("bluerov2-heavy"),
                         parse_sim_options(f"payload={payload},seed={seed},{OPTIONS}"))
    truth = passive_trim_deg(vehicle.truth.mass.net)
    for axis, want in zip(("roll", "pitch"), truth, strict=True):
        error = line[f"{axis}_deg"] - want
        assert abs(error) <= 3 * line[f"{axis}_std_deg"], line
    replayed = subprocess.run([*TRIMD, "replay", str(log), "--json"], capture_output=True,
                              text=True, cwd=REPO, timeout=120, check=True, env=env)
    assert json.loads(replayed.stdout.splitlines()[-1]) == line


def test_the_float_s_correction_levels_the_true_vehicle(bluerov: Profile, tmp_path: Path
                                                        ) -> None:
    """The closed loop through the float: the Heavy's trim (seed 5) and its ballast leave
    it 2.7° rolled, which the thrust map near the dead band hid from the trim; the float
    finds it to 0.2°, and the correction from the attitude it floated at (the prediction
    updated by it, the ballast installed now) leaves the TRUE vehicle within the level
    tolerance or its own predicted trim ± 95 %, and nearer level than before; the app's
    use case proposes the same correction. The history keeps the chain: trim → apply →
    float → correction → apply, and what a verify hold then checks is the correction."""
    payload, seed = "0.4@W-aft-stbd", 5
    trim = sim_trim(bluerov, payload, seed, OPTIONS)
    proposal, estimate = trim.result.proposal, trim.result.estimate
    assert isinstance(proposal, Proposal) and estimate is not None
    loads = change_loads(bluerov, proposal.installed, proposal.installed_after)
    f = float_on_sim(bluerov, f"{payload}+{ballast_payload(proposal, bluerov)}", seed,
                     depth_excursion_m=2.0)
    assert f.result.phase is Phase.DONE and f.r.verdict is Verdict.NOT_LEVEL, f.r
    c = propose_float_correction(f.r, estimate, loads, bluerov, proposal.installed_after)
    assert c.proposal.feasible and c.proposal.pieces_handled >= 1, c.proposal.message
    before, after = true_trim_deg(trim, loads), true_trim_deg(trim, loads, c.proposal.slots)
    assert_levels_as_said(bluerov, after, c)
    assert np.max(np.abs(after)) < np.max(np.abs(before)), (before, after)
    target = VerifyTarget(estimate, tuple(loads))
    with_history = replace(bluerov, installed=proposal.installed_after)
    same = float_correction(f.r, target, with_history, None, "rov")
    assert same is not None and same.proposal.slots == c.proposal.slots
    db = tmp_path / "h.db"
    with History(db) as h:
        h.record_trim("rov", bluerov.name, 1.0, estimate_to_dict(estimate),
                      proposal_to_dict(proposal))
    apply_ballast(db, "rov", bluerov, estimate=estimate, proposal=proposal)
    assert store_float_check(db, "rov", bluerov, f.result, same) is not None
    apply_ballast(db, "rov", bluerov, estimate=same.vehicle, proposal=same.proposal)
    with History(db) as h:
        (floated,), (linked,) = h.float_checks("rov"), h.corrections("rov")
    assert floated.values["verdict"] == "not level" and linked.float_id == floated.id
    now = replace(bluerov, installed=same.proposal.installed_after)
    checked = trim_target(None, now, db, "rov")
    assert np.array_equal(checked.estimate.q, same.vehicle.q)
    assert [(ld.name, ld.pieces, ld.removed, ld.net_down_N) for ld in checked.loads] == [
        (ld.name, ld.pieces, ld.removed, ld.net_down_N) for ld in same.proposal.slots]
