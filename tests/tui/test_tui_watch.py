"""The live watch's terminal UI on the simulated vehicle: it plots and logs the segments,
shows an alert in the log, never commands, and quits on ``q``."""

from __future__ import annotations

import pytest
from textual.widgets import RichLog, Static

from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Command
from trimd.core.watch import TrimWatch, WatchAlert, WatchSegment
from trimd.drivers.sim.config import parse_sim_options
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle
from trimd.tui.watch_app import WatchApp


class PassiveSimLink(SimLink):
    async def send(self, command: Command) -> None:
        raise AssertionError(f"the watch sent {command!r}")


@pytest.mark.slow
@pytest.mark.asyncio
async def test_watch_tui_shows_segments_and_the_alert_of_a_lost_piece() -> None:
    profile = load_profile("bluerov2-heavy")
    link = PassiveSimLink(SimVehicle(profile, parse_sim_options(
        "pilot=dive,seed=7,drop=lead-200g@W-aft-ctr@300")))
    app = WatchApp(link, TrimWatch(profile), until_s=560.0)
    async with app.run_test(size=(100, 30)) as pilot:
        while not any(isinstance(r, WatchAlert) for r in app.records):
            await pilot.pause(0.2)
            assert not app.trim_watch.segments or app.trim_watch.segments[-1].estimate.t_end_s \
                < 560, "no alert within the dive"
        log = app.query_one("#log", RichLog)
        text = " ".join(line.text for line in log.lines)
        assert "ALERT: lighter by" in text and "segment 1 (baseline)" in text
        plot = str(app.query_one("#plot", Static).render())
        assert any(0x2801 <= ord(c) <= 0x28FF for c in plot), plot   # a line is drawn
        await pilot.press("q")
    assert any(isinstance(r, WatchSegment) for r in app.records)
    assert link._closed
