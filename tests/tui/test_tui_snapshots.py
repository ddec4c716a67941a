"""SVG snapshots of the main screen at 80×24 and 120×40, during a hold, with the
proposal shown, with the offer of apply and verify after the trim, and with a verify
hold's verdict. Deterministic: seeded fake vehicle, session time, a fixed clock for the
heartbeat age, and no Ticks (the session's quiet-link clock) while the link is paused."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from textual.pilot import Pilot

from tests.helpers import FakeLink, carried
from tests.tui.tui_helpers import (
    PausedLink,
    RecordingSimLink,
    app_for,
    recording_sim_link,
    thesis_vehicle,
    until,
)
from trimd.app.after_trim import AfterTrim
from trimd.core.profile import Profile
from trimd.tui import TrimApp
from trimd.tui.event_log import EventLog
from trimd.tui.result_panel import ResultPanel

#: sample time alone (tests/tui/conftest.py): a busy machine is no lost link
pytestmark = pytest.mark.usefixtures("no_ticks")
SIZES = [(80, 24), (120, 40)]
#: Mid-way through hold 2's settling (hold 2 is commanded at 29.95 s): tilting to 20°.
HOLD_AT_S = 40.0




@pytest.mark.slow
@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_during_a_hold(snap_compare: Callable[..., bool], sabertooth: Profile,
                       size: tuple[int, int]) -> None:
    link = PausedLink(thesis_vehicle(sabertooth), pause_at=HOLD_AT_S)
    app = app_for(sabertooth, link, confirmed=True)

    async def run_before(pilot: Pilot[Any]) -> None:
        await until(pilot, lambda: link.t > HOLD_AT_S)  # paused: all before it is shown
        await pilot.pause(0.3)  # the live panels redraw at 10 Hz

    assert snap_compare(app, terminal_size=size, run_before=run_before)


@pytest.mark.slow
@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_with_the_proposal(snap_compare: Callable[..., bool], sabertooth: Profile,
                           size: tuple[int, int]) -> None:
    link = FakeLink(thesis_vehicle(sabertooth))
    app = app_for(sabertooth, link, confirmed=True)

    async def run_before(pilot: Pilot[Any]) -> None:
        await until(pilot, lambda: app.result is not None
                    and app.query_one(ResultPanel).proposal is not None)
        await pilot.pause(0.3)

    assert snap_compare(app, terminal_size=size, run_before=run_before)


@pytest.fixture
def after_sabertooth(sabertooth: Profile, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                     ) -> Callable[[], Any]:
    """The TUI over a confirmed trim of the simulated Sabertooth (10 kg at AftSB), with a
    history at ``h.db`` in the current directory (the paths shown do not vary) and a verify
    hold on the simulated vehicle with the applied ballast fitted; not recorded."""
    monkeypatch.chdir(tmp_path)

    async def build() -> TrimApp:
        link = await recording_sim_link("payload=10@AftSB,seed=1", sabertooth)
        app = app_for(sabertooth, link, confirmed=True, link_description="sim:10@AftSB")

        async def fitted() -> RecordingSimLink:
            applied = app.followup.applied
            assert applied is not None
            extra = carried(applied.loads, sabertooth.gravity_m_s2)
            return await recording_sim_link(f"payload=10@AftSB+{extra},seed=2", sabertooth)

        app.followup.after = AfterTrim(Path("h.db"), "rov", sabertooth, True, fitted,
                                       lambda kind, block: None)
        return app
    return build


@pytest.mark.slow
@pytest.mark.parametrize("size", [(80, 24)], ids=lambda s: f"{s[0]}x{s[1]}")
def test_offer_after_the_trim(snap_compare: Callable[..., bool],
                              after_sabertooth: Callable[[], Any],
                              size: tuple[int, int]) -> None:
    app = asyncio.run(after_sabertooth())

    def stored() -> bool:  # the last message: the trim is in the history
        return any("trim history: stored" in text
                   for _, _, text in app.query_one(EventLog).entries)

    async def run_before(pilot: Pilot[Any]) -> None:
        await until(pilot, lambda: app.result is not None
                    and app.query_one(ResultPanel).proposal is not None and stored())
        await pilot.pause(0.3)
        # the Messages panel follows its last line once laid out; on a busy machine the
        # snapshot can come first
        app.query_one(EventLog).scroll_end(animate=False, immediate=True)
        await pilot.pause(0.1)

    assert snap_compare(app, terminal_size=size, run_before=run_before)


@pytest.mark.slow
@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_verdict_after_apply_and_verify(snap_compare: Callable[..., bool],
                                        after_sabertooth: Callable[[], Any],
                                        size: tuple[int, int]) -> None:
    app = asyncio.run(after_sabertooth())

    async def run_before(pilot: Pilot[Any]) -> None:
        await until(pilot, lambda: app.result is not None)
        await pilot.press("p")
        await pilot.pause()
        await pilot.press("y")
        await until(pilot, lambda: len(app.results) == 2)
        await pilot.pause(0.3)

    assert snap_compare(app, terminal_size=size, run_before=run_before)
