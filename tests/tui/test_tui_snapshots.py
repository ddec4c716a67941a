"""SVG snapshots of the main screen at 80×24 and 120×40, during a hold and with the
proposal shown. Deterministic: seeded fake vehicle, session time, a fixed clock for the
heartbeat age, and no Ticks (the session's quiet-link clock) while the link is paused."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from textual.pilot import Pilot

import trimd.app.session
from tests.helpers import FakeLink
from tests.tui.tui_helpers import PausedLink, app_for, thesis_vehicle, until
from trimd.core.profile import Profile
from trimd.tui.result_panel import ResultPanel

SIZES = [(80, 24), (120, 40)]
#: Mid-way through hold 2's settling (hold 2 is commanded at 29.95 s): tilting to 20°.
HOLD_AT_S = 40.0


@pytest.fixture(autouse=True)
def _no_ticks(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(trimd.app.session, "TICK_S", 1e6)


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_during_a_hold(snap_compare: Callable[..., bool], sabertooth: Profile,
                       size: tuple[int, int]) -> None:
    link = PausedLink(thesis_vehicle(sabertooth), pause_at=HOLD_AT_S)
    app = app_for(sabertooth, link, confirmed=True)

    async def run_before(pilot: Pilot[Any]) -> None:
        await until(pilot, lambda: link.t > HOLD_AT_S)  # paused: all before it is shown
        await pilot.pause(0.3)  # the live panels redraw at 10 Hz

    assert snap_compare(app, terminal_size=size, run_before=run_before)


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
