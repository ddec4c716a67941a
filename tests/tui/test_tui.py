"""The TUI driven by Textual's pilot over a session on FakeLink and on the in-process
simulated vehicle: the whole procedure, method switching, the report, abort mid-hold,
quitting."""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
import os
import signal
from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest
from textual.message import Message
from textual.pilot import Pilot

from tests.helpers import FakeLink, ballast_payload, command_plan, passive_attitude_deg
from tests.tui.tui_helpers import (
    RecordingSimLink,
    app_for,
    never_gives_up,
    never_times_out,
    recording_sim_link,
    thesis_vehicle,
    until,
)
from trimd.app.headless import STOP_SIGNALS, stop_on_signals
from trimd.app.session import SessionResult
from trimd.ballast.propose import METHODS, propose_ballast
from trimd.core.events import Phase
from trimd.core.profile import Profile
from trimd.core.samples import Health, HoldAttitude, Release, Sample, VehicleText
from trimd.tui.event_log import EventLog
from trimd.tui.help_screen import HelpScreen
from trimd.tui.link_panel import LinkPanel
from trimd.tui.messages import NoticeReceived, TelemetryChanged
from trimd.tui.quit_screen import QuitScreen
from trimd.tui.result_panel import ResultPanel
from trimd.tui.stepper import Stepper

#: sample time alone (tests/tui/conftest.py): a busy machine is no lost link
pytestmark = pytest.mark.usefixtures("no_ticks")


def _phase(app: object) -> Phase | None:
    progress = app.query_one(Stepper).progress  # type: ignore[attr-defined]
    return None if progress is None else progress.phase


async def _every_method(pilot: Pilot[object], panel: ResultPanel, result: SessionResult,
                        profile: Profile) -> None:
    """Press ``m`` through lp, line, general and back to milp: each proposal shows, is of
    that method and is what ``trimd ballast`` proposes for the session's estimate."""
    assert panel.method == "milp" and panel.proposal is result.proposal
    for method in (*METHODS[:-1], "milp"):  # lp, line, general, back to milp
        await pilot.press("m")
        await until(pilot, lambda m=method: panel.method == m and not panel.busy)
        assert panel.proposal is not None and panel.proposal.method == method
        expected = propose_ballast(result.estimate, profile, method=method)
        got = [(s.name, s.weight_kg, s.float_kg) for s in panel.proposal.slots]
        assert got == [(s.name, s.weight_kg, s.float_kg) for s in expected.slots]
    assert panel.proposal is result.proposal  # milp again: the kept one, not recomputed


async def _saved_report(pilot: Pilot[object], directory: Path, result: SessionResult,
                        profile: Profile) -> tuple[str, dict[str, object]]:
    """Press ``r`` with the milp proposal shown; the markdown and JSON written, checked
    for what every report of a finished session states."""
    await pilot.press("r")
    await pilot.pause()
    stem = directory / f"trimd-{profile.name}"
    md, report = stem.with_suffix(".md").read_text(), json.loads(
        stem.with_suffix(".json").read_text())
    assert report["estimate"]["m_ext_kg"] == pytest.approx(result.estimate.m_ext_kg)
    assert report["method"] == report["proposal"]["method"] == "milp"
    assert report["status"].startswith("done") and report["warnings"] == []
    assert any("release control" in e["text"] for e in report["events"])
    assert "- ballast method: milp" in md and "## Ballast proposal (milp)" in md
    return md, report


@pytest.mark.slow
@pytest.mark.asyncio
async def test_whole_procedure_methods_and_report(sabertooth: Profile, tmp_path: Path) -> None:
    link = FakeLink(thesis_vehicle(sabertooth))
    app = app_for(sabertooth, link, confirmed=False, tmp_path=tmp_path)
    seen: list[Message] = []
    async with app.run_test(size=(80, 24), message_hook=seen.append) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.CONFIRM)
        assert link.sent == []  # nothing commanded before the operator confirms
        await pilot.press("s")
        await until(pilot, lambda: app.result is not None)
        result = app.result
        assert result is not None and result.phase is Phase.DONE, result
        assert isinstance(link.sent[0], HoldAttitude) and isinstance(link.sent[-1], Release)
        panel = app.query_one(ResultPanel)
        assert panel.estimate is result.estimate
        assert panel.method == "milp" and panel.proposal is result.proposal
        assert app.has_class("-result")  # the result replaces the live view

        await _every_method(pilot, panel, result, sabertooth)
        _, report = await _saved_report(pilot, tmp_path, result, sabertooth)
        assert report["link"] == "fake:10@AftSB" and report["truth"] == "10 kg at AftSB"

        await pilot.press("q")  # the session is over: quits without asking
        await pilot.pause()
    assert app.return_value is result
    notices = [m.notice.kind for m in seen if isinstance(m, NoticeReceived)]
    assert notices.count("result") == 1 and "state" in notices
    assert sum(isinstance(m, TelemetryChanged) for m in seen) > 100


@pytest.mark.slow
@pytest.mark.asyncio
async def test_whole_procedure_on_the_simulated_vehicle(sabertooth: Profile,
                                                        tmp_path: Path) -> None:
    """Start, confirm, the proposal, every method and the report, against the simulator;
    the milp proposal then put on the simulated vehicle leaves it level."""
    options = "payload=10@AftSB,seed=1"
    link = await recording_sim_link(options, sabertooth)
    app = app_for(sabertooth, link, confirmed=False, tmp_path=tmp_path,
                  link_description=f"sim:{options}", truth=link.truth())
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.CONFIRM)
        assert link.sent == []  # nothing commanded before the operator confirms
        await pilot.press("s")
        await until(pilot, lambda: app.result is not None)
        result = app.result
        assert result is not None and result.phase is Phase.DONE, result
        # within its own 95 % interval (it carries the thrust curves' 5 %: ≈ ±1 kg)
        assert abs(result.estimate.m_ext_kg - link.vehicle.truth.m_ext_kg) < (
            1.96 * result.estimate.m_ext_std_kg)
        assert command_plan(link.sent) == [(0.0, 0.0), (20.0, 20.0), "release"]
        assert link.vehicle.controller.target[:2] == (0.0, 0.0)  # released: level again
        assert app.query_one(LinkPanel).border_title == "Link · simulated sabertooth-dh2"
        panel = app.query_one(ResultPanel)
        assert panel.proposal is result.proposal and result.proposal.feasible

        await _every_method(pilot, panel, result, sabertooth)
        md, report = await _saved_report(pilot, tmp_path, result, sabertooth)
        assert report["link"] == "sim:payload=10@AftSB,seed=1"
        assert report["truth"] == link.truth() and "payload 10@AftSB" in report["truth"]
        assert f"## Simulator truth\n\n{link.truth()}" in md
        await pilot.press("q")
        await pilot.pause()
    assert app.return_value is result

    ballasted = f"{link.vehicle.config.payload}+{ballast_payload(result.proposal, sabertooth)}"
    assert np.all(np.abs(passive_attitude_deg(sabertooth, ballasted)) < 0.5)


def _in_hold_2(app: object, link: FakeLink) -> bool:
    """Settling in the tilted hold: a tilt was commanded (the first step of its ramp)."""
    return _phase(app) is Phase.SETTLE and any(
        isinstance(c, HoldAttitude) and c.phi != 0.0 for c in link.sent)


def _tilting_in_hold_2(link: RecordingSimLink) -> bool:
    """The tilted hold (20° roll and pitch) reached the vehicle and it is on its way."""
    if len(link.sent) < 2:
        return False
    phi, theta = link.vehicle.truth.eta[3:5]
    return min(phi, theta) > math.radians(5.0)


@pytest.mark.asyncio
async def test_abort_mid_hold_on_the_simulated_vehicle_releases_it(sabertooth: Profile) -> None:
    """Abort while the simulated vehicle tilts into hold 2 (frozen there, so the keypress
    lands mid-hold however slow the runner): the Release reaches the link at that very
    instant, the vehicle's controller drops the tilted set-point and it comes back level."""
    profile = never_gives_up(sabertooth)
    link = await recording_sim_link("payload=10@AftSB,seed=2", profile,
                                    pause_when=_tilting_in_hold_2)
    app = app_for(profile, link, confirmed=True)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: (link.paused_at is not None and _phase(app) is Phase.SETTLE)
                    or app.result is not None)
        assert app.result is None, app.result  # frozen in hold 2, not ended before it
        held = link.vehicle.controller.target  # on its way up the ramp to 20°/20°
        assert held[0] == pytest.approx(held[1])
        assert math.radians(5.0) < held[0] <= math.radians(20.0)
        await pilot.press("a")
        await until(pilot, lambda: app.result is not None)
        assert app.result is not None and app.result.phase is Phase.ABORTED
        assert app.result.reason == "aborted by the operator"
        assert _phase(app) is Phase.ABORTED
    on_ramp = round(math.degrees(held[0]), 2)  # aborted on the way up: released from there
    assert command_plan(link.sent) == [(0.0, 0.0), (on_ramp, on_ramp), "release"]
    t_release, _ = link.commands[-1]
    assert t_release == link.paused_at  # mid-hold: the vehicle took no step in between
    v = link.vehicle
    assert v.controller.target == (0.0, 0.0, held[2])  # level, same heading: not held
    assert v.mode == "ALT_HOLD" and v.armed  # released to the pilot's depth hold
    tilted = np.degrees(v.truth.eta[3:5])
    v.run_for(30.0)  # the session is over: step the released vehicle on by hand
    assert np.all(tilted > 5.0) and np.all(np.abs(np.degrees(v.truth.eta[3:5])) < 1.0)


class ChattyLink(FakeLink):
    """FakeLink whose vehicle, after its first heartbeat, warns about a parameter (as the
    MAVLink link does in Health.detail) and says something for people (STATUSTEXT)."""

    async def samples(self) -> AsyncIterator[Sample]:
        said = False
        async for s in super().samples():
            if isinstance(s, Health) and not said:
                said = True
                yield dataclasses.replace(s, detail="MOT_1_DIRECTION is -1")
                yield VehicleText(s.t_s, 2, "Failsafe: pilot input lost, disarming")
            else:
                yield s


@pytest.mark.asyncio
async def test_link_warnings_and_vehicle_messages_reach_the_messages_panel(
        sabertooth: Profile) -> None:
    app = app_for(sabertooth, ChattyLink(thesis_vehicle(sabertooth)), confirmed=False)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.CONFIRM)
        entries = [(kind, text) for _, kind, text in app.query_one(EventLog).entries]
        assert entries.count(("warning", "MOT_1_DIRECTION is -1")) == 1
        assert ("error", "vehicle: Failsafe: pilot input lost, disarming") in entries
        await pilot.press("a")
        await until(pilot, lambda: app.result is not None)


@pytest.mark.slow
@pytest.mark.asyncio
async def test_abort_mid_hold_from_the_help_screen_releases_at_once(
        sabertooth: Profile) -> None:
    profile = never_times_out(sabertooth)
    link = FakeLink(thesis_vehicle(profile, stuck_at_deg=5.0))  # hold 2 never settles
    app = app_for(profile, link, confirmed=True)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _in_hold_2(app, link))
        await pilot.press("question_mark")
        assert isinstance(app.screen, HelpScreen)
        pressed_at = link.t
        await pilot.press("a")  # abort is available on every screen
        await until(pilot, lambda: app.result is not None)
        assert app.result is not None and app.result.phase is Phase.ABORTED
        assert app.result.reason == "aborted by the operator"
        t_release, last = link.vehicle.commands[-1]
        assert isinstance(last, Release) and t_release - pressed_at < 0.5  # sample time
        assert _phase(app) is Phase.ABORTED


@pytest.mark.asyncio
async def test_quit_while_running_asks_and_aborts_first(sabertooth: Profile) -> None:
    profile = never_times_out(sabertooth)
    link = FakeLink(thesis_vehicle(profile, stuck_at_deg=5.0))  # runs until aborted
    app = app_for(profile, link, confirmed=True)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.SETTLE)
        await pilot.press("q")
        assert isinstance(app.screen, QuitScreen)
        await pilot.press("n")
        assert not isinstance(app.screen, QuitScreen) and app.result is None
        await pilot.press("q")
        await pilot.press("y")
        await until(pilot, lambda: app.result is not None)
        await pilot.pause()
    assert app.return_value is not None and app.return_value.phase is Phase.ABORTED
    assert isinstance(link.sent[-1], Release)


@pytest.mark.asyncio
async def test_closing_the_app_mid_hold_still_releases(sabertooth: Profile) -> None:
    link = FakeLink(thesis_vehicle(sabertooth, stuck_at_deg=5.0))
    app = app_for(sabertooth, link, confirmed=True)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.SETTLE)
        app.exit()
    assert isinstance(link.sent[-1], Release) and link.closed
    assert app.result is not None and app.result.reason == "the terminal UI closed"
    assert not math.isnan(app.state.t_s)


@pytest.mark.asyncio
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
async def test_a_signal_mid_hold_releases_and_quits(sabertooth: Profile,
                                                    sig: signal.Signals) -> None:
    # runs until stopped, and a busy machine's slow event loop is no lost link
    profile = never_gives_up(sabertooth)
    link = FakeLink(thesis_vehicle(profile, stuck_at_deg=5.0))
    app = app_for(profile, link, confirmed=True)
    loop = asyncio.get_running_loop()
    try:
        async with app.run_test(size=(80, 24)) as pilot:
            stop_on_signals(app.stop)  # as trimd run does around the TUI
            await until(pilot, lambda: app.result is not None
                        or _in_hold_2(app, link))
            assert app.result is None, app.result.reason   # still in the tilted hold
            os.kill(os.getpid(), sig)
            await until(pilot, lambda: app.result is not None)
            await pilot.pause()
    finally:
        for s in STOP_SIGNALS:
            loop.remove_signal_handler(s)
    assert isinstance(link.sent[-1], Release) and link.closed  # the release reached the link
    assert app.return_value is app.result  # and the app quit by itself
    assert app.result is not None and app.result.phase is Phase.ABORTED
    assert app.result.reason == f"stopped by {sig.name}"


@pytest.mark.asyncio
async def test_a_hang_up_exits_once_the_vehicle_is_released(
        sabertooth: Profile, monkeypatch: pytest.MonkeyPatch) -> None:
    """SIGHUP (an SSH drop) in the TUI: the session ends (release, log closed), then the
    process leaves without restoring a terminal that is gone (os._exit(1))."""
    from trimd.tui import run as tui_run

    exits: list[tuple[int, bool]] = []
    profile = never_times_out(sabertooth)
    link = FakeLink(thesis_vehicle(profile, stuck_at_deg=5.0))
    app = app_for(profile, link, confirmed=True)
    monkeypatch.setattr(tui_run.os, "_exit",
                        lambda code: exits.append((code, isinstance(link.sent[-1], Release))))
    leaving: set[asyncio.Future[None]] = set()
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _in_hold_2(app, link))
        tui_run._hang_up(app, leaving)
        await until(pilot, lambda: bool(exits))
    assert exits == [(1, True)]  # exit code 1, and only after the release was sent
    assert link.closed and app.result is not None
    assert app.result.reason == "stopped by SIGHUP"
