"""After a trim in the TUI: apply (the proposal recorded as installed ballast, as
``trimd ballast apply`` records it) and verify (a level hold of the vehicle with that
ballast actually fitted, commanded only after the operator confirms), on the simulated
vehicle; the verdict shows, the history holds trim, installation and verification in
order, and the verify hold's recording replays to the same verdict, whether the operator
confirmed it or ``--yes`` did."""

from __future__ import annotations

import asyncio
import json
import sys
from collections.abc import Awaitable, Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from textual.pilot import Pilot

from tests.helpers import carried, passive_attitude_deg
from tests.tui.tui_helpers import RecordingSimLink, app_for, recording_sim_link, until
from trimd.app.after_trim import AfterTrim
from trimd.app.apply import Applied
from trimd.app.history import History
from trimd.app.replay import replay_session
from trimd.app.session import SessionResult
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import Verification, verification_to_dict
from trimd.core.events import Phase
from trimd.core.floating import FloatResult, Verdict, float_to_dict
from trimd.core.profile import Profile
from trimd.core.profile_yaml import read_profile_text
from trimd.core.samples import HoldAttitude, Release
from trimd.logs.recorder import TlogRecorder
from trimd.logs.replay import recorded_verify_target
from trimd.tui import TrimApp
from trimd.tui.next_steps import NextSteps
from trimd.tui.result_panel import ResultPanel
from trimd.tui.stepper import Stepper
from trimd.tui.verdict_panel import VerdictPanel

#: sample time alone (tests/tui/conftest.py): a busy machine is no lost link
pytestmark = pytest.mark.usefixtures("no_ticks")
PAYLOAD = "10@AftSB"




def _phase(app: TrimApp) -> Phase | None:
    progress = app.query_one(Stepper).progress
    return None if progress is None else progress.phase


async def _confirm_the_trim(pilot: Pilot[Any], app: TrimApp) -> SessionResult | None:
    """The operator confirms when the trim asks; the trim's result once it ended."""
    await until(pilot, lambda: _phase(app) is Phase.CONFIRM)
    await pilot.press("s")
    await until(pilot, lambda: app.result is not None)
    return app.result


class Vehicle:
    """The simulated vehicle's links: the trim's, then the verify holds', which carry
    what the operator recorded as installed each time (the pilot fitted it) unless
    ``fitted`` is False; the first ``unfitted`` records the pilot did not fit."""

    def __init__(self, profile: Profile, *, fitted: bool = True, unfitted: int = 0) -> None:
        self.profile, self.fitted, self.unfitted = profile, fitted, unfitted
        self.links: list[RecordingSimLink] = []
        self.app: TrimApp | None = None
        self.recorded: list[Applied] = []  # every record verified so far, in order

    def awaiting_operator(self, link: RecordingSimLink) -> bool:
        """The procedure waits for the operator's confirmation: no sample meanwhile (with
        no quiet-link Ticks either, the result does not depend on the key's timing)."""
        return self.app is not None and self.app.session.procedure.phase is Phase.CONFIRM

    async def open(self) -> RecordingSimLink:
        assert self.app is not None
        applied = self.app.followup.applied
        assert applied is not None  # verify is offered only after apply
        if applied not in self.recorded:
            self.recorded.append(applied)
        fitted = self.recorded[self.unfitted:] if self.fitted else []
        extra = "+".join(carried(a.loads, self.profile.gravity_m_s2) for a in fitted)
        payload = f"{PAYLOAD}+{extra}" if extra else PAYLOAD
        link = await recording_sim_link(f"payload={payload},seed={len(self.links) + 1}",
                                        self.profile, hold_while=self.awaiting_operator)
        self.links.append(link)
        return link


async def trim_app(profile: Profile, tmp_path: Path, *, confirmed: bool,
                   vehicle: Vehicle | None = None,
                   open_link: Callable[[], Awaitable[RecordingSimLink]] | None = None,
                   history: bool = True) -> TrimApp:
    """The TUI over a trim of the simulated vehicle (PAYLOAD, seed 1) as ``trimd run``
    builds it: the history ``h.db`` (``history`` False: ``--no-history``) and the checks'
    link from ``vehicle`` (or ``open_link``), recorded to ``verify.tlog`` or
    ``float.tlog``."""
    vehicle = vehicle or Vehicle(profile)
    link = await recording_sim_link(f"payload={PAYLOAD},seed=1", profile,
                                    hold_while=vehicle.awaiting_operator)
    app = app_for(profile, link, confirmed=confirmed, tmp_path=tmp_path)
    vehicle.app = app

    def recorder(kind: str, block: dict[str, Any]) -> TlogRecorder:
        blocks = {"float_check" if kind == "float" else "verify_target": block}
        return TlogRecorder(tmp_path / f"{kind}.tlog", profile,
                            read_profile_text(profile.name)[0], **blocks)

    app.followup.after = AfterTrim(tmp_path / "h.db" if history else None, "rov", profile,
                                   confirmed, open_link or vehicle.open, recorder)
    return app


@pytest.mark.slow
@pytest.mark.asyncio
async def test_apply_then_verify_on_the_simulated_vehicle(sabertooth: Profile,
                                                          tmp_path: Path) -> None:
    vehicle = Vehicle(sabertooth)
    app = await trim_app(sabertooth, tmp_path, confirmed=False, vehicle=vehicle)
    async with app.run_test(size=(80, 24)) as pilot:
        trim = await _confirm_the_trim(pilot, app)
        assert trim is not None and trim.phase is Phase.DONE, trim
        proposal = trim.proposal
        assert isinstance(proposal, Proposal) and proposal.feasible
        assert app.query_one(NextSteps).has_class("-shown")
        assert app.check_action("apply", ()) and not app.check_action("verify", ())

        await pilot.press("y")  # verify before apply: not offered, nothing happens
        await pilot.pause()
        assert vehicle.links == []
        panel = app.query_one(ResultPanel)
        await pilot.press("m")  # lp shown: ideal amounts, no pieces to install
        await until(pilot, lambda: panel.method == "lp" and panel.proposal is not None)
        await pilot.press("p")
        await pilot.pause()
        applied = app.followup.applied
        assert applied is not None and applied.source == "proposal"
        assert applied.installed == proposal.installed_after  # the milp pieces, shown now
        assert panel.method == "milp" and panel.proposal is proposal
        assert not app.check_action("apply", ()) and app.check_action("verify", ())

        await pilot.press("y")
        await until(pilot, lambda: bool(vehicle.links) and _phase(app) is Phase.CONFIRM)
        verify_link = vehicle.links[0]
        assert verify_link.sent == []  # nothing commanded before the operator confirms
        steps = app.query_one(Stepper).steps
        assert app.result is None and len(steps) == 1 and steps[0].startswith("hold 1/1")
        await pilot.press("s")
        await until(pilot, lambda: app.result is not None)
        result = app.result
        assert result is not None and result.phase is Phase.DONE, result
        v = result.verification
        assert isinstance(v, Verification)
        assert v.as_predicted and v.level, v.message
        # the measured residual trim is the true one (the simulator's, with the ballast)
        fitted = f"{PAYLOAD}+{carried(applied.loads, sabertooth.gravity_m_s2)}"
        truth = passive_attitude_deg(sabertooth, fitted)
        measured, sigma = (np.array([v.roll_deg, v.pitch_deg]),
                           np.array([v.roll_std_deg, v.pitch_std_deg]))
        assert np.all(np.abs(measured - truth) <= 1.96 * sigma), (measured, truth, sigma)
        assert [type(c) for c in verify_link.sent] == [HoldAttitude, Release]
        assert verify_link.sent[0].phi == verify_link.sent[0].theta == 0.0
        assert app.query_one(VerdictPanel).verification is v
        assert app.has_class("-verdict")
        await pilot.press("r")  # the report: the trim and, now, the verify hold's verdict
        await pilot.pause()
        report = json.loads((tmp_path / "verify-report.json").read_text())
        assert report["verification"]["as_predicted"] and report["warnings"] == []
        assert report["proposal"]["installed_after"] == [
            {"slot": x.slot, "piece": x.piece, "count": x.count} for x in applied.installed]
        assert "## Verify hold" in (tmp_path / "verify-report.md").read_text()
        await pilot.press("q")
        await pilot.pause()
    assert app.results == [trim, result]

    with History(tmp_path / "h.db") as history:
        trims, installs = history.trims("rov"), history.installs("rov")
        verifications = history.verifications("rov")
    assert len(trims) == len(installs) == len(verifications) == 1
    assert trims[0].t_unix <= installs[0].t_unix <= verifications[0].t_unix
    assert installs[0].pieces == proposal.installed_after
    assert verifications[0].values["as_predicted"] is True

    # the recording replays to the same verdict: confirmed where the operator confirmed
    recording = tmp_path / "verify.tlog"
    assert recorded_verify_target(recording) is not None
    replayed, _ = await replay_session(str(recording), sabertooth, speed=None, presenters=[],
                                       method="milp")
    assert isinstance(replayed.verification, Verification)
    assert verification_to_dict(replayed.verification) == verification_to_dict(v)


@pytest.mark.slow
@pytest.mark.asyncio
async def test_apply_then_float_on_the_simulated_vehicle(sabertooth: Profile,
                                                        tmp_path: Path) -> None:
    """After apply, ``f``: a float check on the link opened again (the thrusters at
    neutral, nothing before the operator confirms), its attitude the TRUE vehicle's
    passive trim with the ballast within its ± (3σ), shown in the verdict panel, stored
    in the history, recorded so that a replay gives the same result; a float not found
    level offers its correction (apply), one that is level offers the checks again. The
    ballasted Sabertooth rises while it settles: the profile's depth envelope, 10 m
    instead of 1 m (the simulator has no surface), lets it settle."""
    sabertooth = replace(sabertooth, procedure=replace(sabertooth.procedure,
                                                       max_depth_excursion_m=10.0))
    vehicle = Vehicle(sabertooth)
    app = await trim_app(sabertooth, tmp_path, confirmed=False, vehicle=vehicle)
    async with app.run_test(size=(80, 24)) as pilot:
        await _confirm_the_trim(pilot, app)
        assert not app.check_action("float", ())
        await pilot.press("p")
        await pilot.pause()
        applied = app.followup.applied
        assert applied is not None and app.check_action("float", ())
        await pilot.press("f")
        await until(pilot, lambda: bool(vehicle.links) and _phase(app) is Phase.CONFIRM)
        float_link = vehicle.links[0]
        assert float_link.sent == [] and app.query_one(Stepper).steps == [
            "float: thrusters at neutral"]
        await pilot.press("s")
        await until(pilot, lambda: len(app.results) == 2)
        result = app.result
        assert result is not None and result.phase is Phase.DONE, result
        f = result.verification
        assert isinstance(f, FloatResult)
        fitted = f"{PAYLOAD}+{carried(applied.loads, sabertooth.gravity_m_s2)}"
        truth = passive_attitude_deg(sabertooth, fitted)
        floated, sigma = (np.array([f.roll_deg, f.pitch_deg]),
                          np.array([f.roll_std_deg, f.pitch_std_deg]))
        assert np.all(np.abs(floated - truth) <= 3 * sigma), (floated, truth, sigma)
        assert Release in [type(c) for c in float_link.sent]
        assert not any(isinstance(c, HoldAttitude) for c in float_link.sent)
        assert app.query_one(VerdictPanel).verification is f and app.has_class("-verdict")
        offered = str(app.query_one(NextSteps).render())
        if f.verdict is Verdict.LEVEL:
            assert app.followup.correction is None and "float again" in offered
        else:
            assert app.followup.correction is not None and app.check_action("apply", ())
            assert "apply the correction" in offered
        await pilot.press("q")
        await pilot.pause()
    with History(tmp_path / "h.db") as history:
        (stored,) = history.float_checks("rov")
        corrections = history.corrections("rov")
    assert stored.values["verdict"] == f.verdict.value
    assert [c.float_id for c in corrections] == (
        [] if f.verdict is Verdict.LEVEL else [stored.id])
    replayed, _ = await replay_session(str(tmp_path / "float.tlog"), sabertooth, speed=None,
                                       presenters=[], method="milp")
    assert isinstance(replayed.verification, FloatResult)
    assert float_to_dict(replayed.verification) == float_to_dict(f)


@pytest.mark.slow
@pytest.mark.asyncio
async def test_ballast_not_fitted_is_not_as_predicted(sabertooth: Profile,
                                                      tmp_path: Path) -> None:
    """Confirmed up front (``--yes``) the verify hold starts at once; the pilot did not fit
    the ballast recorded, and the verdict says so, naming the moments."""
    vehicle = Vehicle(sabertooth, fitted=False)
    app = await trim_app(sabertooth, tmp_path, confirmed=True, vehicle=vehicle)
    async with app.run_test(size=(80, 24)) as pilot:
        await _apply_and_verify(pilot, app)
        result = app.result
        assert result is not None and isinstance(result.verification, Verification)
        v = result.verification
        assert not v.as_predicted and not v.level
        assert "NOT as predicted" in v.message and "W·x_g − B·x_b off by" in v.message
        assert app.query_one(VerdictPanel).has_class("-off")
        await pilot.press("r")
        await pilot.pause()
        warnings = json.loads((tmp_path / "verify-report.json").read_text())["warnings"]
        assert warnings == [f"the verify hold: {v.message}"]
    # confirmed up front: the recording reproduces the verdict exactly too
    replayed, _ = await replay_session(str(tmp_path / "verify.tlog"), sabertooth, speed=None,
                                       presenters=[], method="milp")
    assert isinstance(replayed.verification, Verification)
    assert verification_to_dict(replayed.verification) == verification_to_dict(v)


@pytest.mark.slow
@pytest.mark.asyncio
async def test_correction_apply_and_verify_again(sabertooth: Profile, tmp_path: Path) -> None:
    """The chain trim → apply → verify → correction → apply → verify: the pilot did not fit
    the first ballast recorded, the verify hold finds the vehicle not level and offers its
    correction; ``p`` records it, the pilot fits it, ``y`` verifies it as predicted. The
    history holds the chain in order, the correction linked to the verify hold it came
    from."""
    vehicle = Vehicle(sabertooth, unfitted=1)
    app = await trim_app(sabertooth, tmp_path, confirmed=True, vehicle=vehicle)
    async with app.run_test(size=(120, 40)) as pilot:
        await _apply_and_verify(pilot, app)
        first = app.result
        assert first is not None and isinstance(first.verification, Verification)
        assert not first.verification.level
        correction = app.followup.correction
        assert correction is not None and app.check_action("apply", ())
        assert "apply the correction" in str(app.query_one(NextSteps).content)
        await pilot.press("p")
        await pilot.pause()
        assert app.followup.correction is None and not app.check_action("apply", ())
        applied = app.followup.applied
        assert applied is not None
        assert applied.installed == correction.proposal.installed_after
        await pilot.press("y")
        await until(pilot, lambda: len(app.results) == 3)
        second = app.results[-1].verification
        assert isinstance(second, Verification) and second.as_predicted, second.message
    with History(tmp_path / "h.db") as history:
        trims, installs = history.trims("rov"), history.installs("rov")
        verifications, corrections = history.verifications("rov"), history.corrections("rov")
    assert (len(trims), len(installs), len(verifications)) == (1, 2, 2)
    assert corrections and corrections[0].verify_id == verifications[0].id
    assert (trims[0].t_unix <= installs[0].t_unix <= verifications[0].t_unix
            == corrections[0].t_unix <= installs[1].t_unix <= verifications[1].t_unix)


async def _apply_then_verify(pilot: Pilot[Any], app: TrimApp) -> SessionResult | None:
    """Once the trim has ended: ``p`` (apply), then ``y`` (verify); the trim's result."""
    await until(pilot, lambda: app.result is not None)
    trim = app.result
    await pilot.press("p")
    await pilot.pause()
    await pilot.press("y")
    return trim


async def _apply_and_verify(pilot: Pilot[Any], app: TrimApp) -> None:
    await _apply_then_verify(pilot, app)
    await until(pilot, lambda: len(app.results) == 2)


@pytest.mark.slow
@pytest.mark.asyncio
async def test_verify_link_that_does_not_open_is_a_message(sabertooth: Profile,
                                                           tmp_path: Path) -> None:
    """The link cannot be opened again: the next-steps panel says why (no traceback) and
    offers verify again; the trim's result stays."""
    from trimd.core.errors import LinkError

    async def no_link() -> RecordingSimLink:
        raise LinkError("udp:0.0.0.0:14550: address in use")

    app = await trim_app(sabertooth, tmp_path, confirmed=True, open_link=no_link)
    async with app.run_test(size=(80, 24)) as pilot:
        trim = await _apply_then_verify(pilot, app)
        await until(pilot, lambda: not app.followup.opening)
        await asyncio.sleep(0)
        await pilot.pause()
        assert app.result is trim and app.check_action("verify", ())
        assert "address in use" in str(app.query_one(NextSteps).content)


@pytest.mark.slow
def test_trimd_run_in_the_terminal_ui_apply_and_verify(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """``trimd run`` with the terminal UI: trim, apply, verify on the same URL (a new
    simulated vehicle: nobody fitted the ballast, so NOT as predicted), quit. The history
    holds each once, in order; both sessions are printed and recorded, the verify
    recording beside the trim's, and it replays to the same verdict."""
    import trimd.tui.run
    from trimd.cli.main import main
    from trimd.core.profile_yaml import load_profile

    async def drive(app: TrimApp) -> object:
        async with app.run_test(size=(80, 24)) as pilot:
            await until(pilot, lambda: _phase(app) is Phase.CONFIRM)
            await pilot.press("s")
            await until(pilot, lambda: app.result is not None)
            await pilot.press("p")
            await pilot.pause()
            await pilot.press("y")
            await until(pilot, lambda: app.result is None and _phase(app) is Phase.CONFIRM)
            await pilot.press("s")
            await until(pilot, lambda: len(app.results) == 2)
            await pilot.press("q")
        return app.result

    for stream in (sys.stdin, sys.stdout):   # a terminal is attached: the TUI
        monkeypatch.setattr(stream, "isatty", lambda: True)
    monkeypatch.setattr(trimd.tui.run, "run_in_tui", drive)
    db, log = tmp_path / "h.db", tmp_path / "trim.tlog"
    assert main(["run", "--link", "sim:payload=10@AftSB", "--profile", "sabertooth-dh2",
                 "--db", str(db), "--vehicle", "rov", "--record", str(log)]) == 0
    out, err = capsys.readouterr()
    assert "ballast by milp" in out and "verify hold (" in out
    assert "NOT as predicted" in out
    verify_logs = sorted(tmp_path.glob("trim-verify-*.tlog"))
    assert len(verify_logs) == 1
    assert f"session log: {log}" in err and f"session log: {verify_logs[0]}" in err
    with History(db) as history:
        assert len(history.trims("rov")) == len(history.installs("rov")) == 1
        verifications = history.verifications("rov")
    assert len(verifications) == 1 and verifications[0].values["as_predicted"] is False
    replayed, _ = asyncio.run(replay_session(str(verify_logs[0]), load_profile(
        "sabertooth-dh2"), speed=None, presenters=[], method="milp"))
    assert isinstance(replayed.verification, Verification)
    again = verification_to_dict(replayed.verification)
    assert (again["measured_N_Nm"], again["message"]) == (
        verifications[0].values["measured_N_Nm"], verifications[0].values["message"])


@pytest.mark.slow
@pytest.mark.asyncio
async def test_without_a_history_apply_and_verify_are_not_offered(
        sabertooth: Profile, tmp_path: Path) -> None:
    app = await trim_app(sabertooth, tmp_path, confirmed=True, history=False)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: app.result is not None)
        await pilot.pause()
        assert not app.check_action("apply", ()) and not app.check_action("verify", ())
        assert "not with --no-history" in str(app.query_one(NextSteps).content)
    assert not (tmp_path / "h.db").exists()


@pytest.mark.slow
@pytest.mark.asyncio
async def test_abort_while_the_link_opens_starts_no_verify_hold(sabertooth: Profile,
                                                                tmp_path: Path) -> None:
    """Confirmed up front (``--yes``), a verify hold would command as soon as its link is
    open: ABORT pressed while it opens cancels it, and nothing is commanded."""
    async def slow_link() -> RecordingSimLink:
        await asyncio.Event().wait()  # a link that takes its time to answer
        raise AssertionError("not reached")

    app = await trim_app(sabertooth, tmp_path, confirmed=True, open_link=slow_link)
    async with app.run_test(size=(80, 24)) as pilot:
        trim = await _apply_then_verify(pilot, app)
        await until(pilot, lambda: app.followup.opening)
        await pilot.press("a")
        await until(pilot, lambda: all(w.is_finished for w in app.workers
                                       if w.group == "verify"))
        assert not app.followup.opening and app.result is trim and app.results == [trim]
        assert "verify cancelled" in str(app.query_one(NextSteps).content)
        assert app.check_action("verify", ())


@pytest.mark.slow
@pytest.mark.asyncio
async def test_a_replayed_verify_hold_shows_its_verdict(sabertooth: Profile,
                                                        tmp_path: Path) -> None:
    """``trimd replay`` of a verify hold in the terminal UI: the verdict panel, no offer."""
    from trimd.tui.replay_app import replay_app

    vehicle = Vehicle(sabertooth)
    app = await trim_app(sabertooth, tmp_path, confirmed=True, vehicle=vehicle)
    async with app.run_test(size=(80, 24)) as pilot:
        await _apply_and_verify(pilot, app)
    live = app.results[-1].verification
    assert isinstance(live, Verification)
    replay = replay_app(str(tmp_path / "verify.tlog"), sabertooth, speed=float("inf"),
                        method="milp")
    async with replay.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: replay.result is not None)
        await pilot.pause()
        shown = replay.query_one(VerdictPanel).verification
        assert shown is not None and replay.has_class("-verdict")
        assert verification_to_dict(shown) == verification_to_dict(live)
        assert not replay.query_one(NextSteps).has_class("-shown")
        assert not replay.check_action("start", ())  # a replay confirms where live did
