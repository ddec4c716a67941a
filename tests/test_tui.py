"""The TUI driven by Textual's pilot over a session on FakeLink: the whole procedure,
method switching, the report, abort mid-hold, quitting."""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
import os
import signal
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
from textual.message import Message

from drivers import open_link
from tests.fake_vehicle import FakeLink
from tests.tui_helpers import app_for, never_times_out, thesis_vehicle, until
from trimd.ballast import METHODS, propose_ballast
from trimd.cmd_run import STOP_SIGNALS, stop_on_signals
from trimd.procedure import Phase
from trimd.profile import Profile
from trimd.samples import Health, HoldAttitude, Release, Sample, VehicleText
from trimd.tui.event_log import EventLog
from trimd.tui.help_screen import HelpScreen
from trimd.tui.link_panel import LinkPanel
from trimd.tui.messages import NoticeReceived, TelemetryChanged
from trimd.tui.quit_screen import QuitScreen
from trimd.tui.result_panel import ResultPanel
from trimd.tui.stepper import Stepper


def _phase(app: object) -> Phase | None:
    progress = app.query_one(Stepper).progress  # type: ignore[attr-defined]
    return None if progress is None else progress.phase


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

        for method in (*METHODS[:-1], "milp"):  # lp, line, general, back to milp
            await pilot.press("m")
            await until(pilot, lambda m=method: panel.method == m and not panel.busy)
            assert panel.proposal is not None and panel.proposal.method == method
            expected = propose_ballast(result.estimate, sabertooth, method=method)
            got = [(s.name, s.weight_kg, s.float_kg) for s in panel.proposal.slots]
            assert got == [(s.name, s.weight_kg, s.float_kg) for s in expected.slots]
        assert panel.proposal is result.proposal  # milp again: the kept one, not recomputed

        await pilot.press("r")
        await pilot.pause()
        md, js = tmp_path / "trimd-sabertooth-dh2.md", tmp_path / "trimd-sabertooth-dh2.json"
        report = json.loads(js.read_text())
        assert report["estimate"]["m_ext_kg"] == pytest.approx(result.estimate.m_ext_kg)
        assert report["proposal"]["method"] == "milp"
        assert report["status"].startswith("done")
        assert any("release control" in e["text"] for e in report["events"])
        assert "## Ballast proposal (milp)" in md.read_text()

        await pilot.press("q")  # the session is over: quits without asking
        await pilot.pause()
    assert app.return_value is result
    notices = [m.notice.kind for m in seen if isinstance(m, NoticeReceived)]
    assert notices.count("result") == 1 and "state" in notices
    assert sum(isinstance(m, TelemetryChanged) for m in seen) > 100


@pytest.mark.asyncio
async def test_whole_procedure_on_the_simulated_vehicle(sabertooth: Profile) -> None:
    link = await open_link("sim:payload=10@AftSB,seed=1", sabertooth)
    app = app_for(sabertooth, link, confirmed=False)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.CONFIRM)
        await pilot.press("s")
        await until(pilot, lambda: app.result is not None)
        result = app.result
        assert result is not None and result.phase is Phase.DONE, result
        assert abs(result.estimate.m_ext_kg - 10.0) < 0.2  # issue 6's tolerance
        assert app.query_one(LinkPanel).border_title == "Link · simulated sabertooth-dh2"
        panel = app.query_one(ResultPanel)
        assert panel.proposal is result.proposal and result.proposal.feasible
        await pilot.press("m")
        await until(pilot, lambda: panel.method == "lp" and not panel.busy)
        assert panel.proposal is not None and panel.proposal.method == "lp"


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


@pytest.mark.asyncio
async def test_abort_mid_hold_from_the_help_screen_releases_at_once(
        sabertooth: Profile) -> None:
    profile = never_times_out(sabertooth)
    link = FakeLink(thesis_vehicle(profile, stuck_at_deg=5.0))  # hold 2 never settles
    app = app_for(profile, link, confirmed=True)
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.SETTLE and len(link.sent) == 2)
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
    profile = never_times_out(sabertooth)
    link = FakeLink(thesis_vehicle(profile, stuck_at_deg=5.0))  # runs until stopped
    app = app_for(profile, link, confirmed=True)
    loop = asyncio.get_running_loop()
    try:
        async with app.run_test(size=(80, 24)) as pilot:
            stop_on_signals(app.stop)  # as trimd run does around the TUI
            await until(pilot, lambda: _phase(app) is Phase.SETTLE and len(link.sent) == 2)
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
    from trimd import cmd_run

    exits: list[tuple[int, bool]] = []
    profile = never_times_out(sabertooth)
    link = FakeLink(thesis_vehicle(profile, stuck_at_deg=5.0))
    app = app_for(profile, link, confirmed=True)
    monkeypatch.setattr(cmd_run.os, "_exit",
                        lambda code: exits.append((code, isinstance(link.sent[-1], Release))))
    leaving: set[asyncio.Future[None]] = set()
    async with app.run_test(size=(80, 24)) as pilot:
        await until(pilot, lambda: _phase(app) is Phase.SETTLE and len(link.sent) == 2)
        cmd_run._hang_up(app, leaving)
        await until(pilot, lambda: bool(exits))
    assert exits == [(1, True)]  # exit code 1, and only after the release was sent
    assert link.closed and app.result is not None
    assert app.result.reason == "stopped by SIGHUP"
