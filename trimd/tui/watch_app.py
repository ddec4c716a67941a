"""The terminal UI of the live trim watch: W − B over the dive, the segments and alerts.

A braille plot of each segment's W − B (and the baseline once formed) over sample time,
the latest segment and the verdict so far, and a log of segments and alerts (alerts in
red). The watch itself (:func:`trimd.app.watch.watch_link`) runs as a worker; it sends
nothing to the vehicle. ``q`` quits (the watch stops and the link closes).
"""

from __future__ import annotations

import asyncio
import math
from typing import ClassVar

from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.widgets import Footer, Header, RichLog, Static

from trimd.app.watch import Record, format_record, verdict, watch_link
from trimd.core.link import Link
from trimd.core.watch import TrimWatch, WatchAlert
from trimd.tui.plot import Series, braille_plot, y_range

__all__ = ["WatchApp"]


class WatchApp(App[None]):
    """Watch ``link`` with ``watch`` until quit (or ``until_s`` of sample time)."""

    CSS = """
    #plot { height: 12; border: round $primary; }
    #status { height: 3; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [Binding("q", "quit_watch", "quit")]

    def __init__(self, link: Link, watch: TrimWatch, *, until_s: float | None = None) -> None:
        super().__init__()
        self.link, self.trim_watch, self.until_s = link, watch, until_s
        self.stop_event = asyncio.Event()
        self.records: list[Record] = []
        self.title = f"trimd watch — {link.description} (passive: sends no command)"

    def compose(self) -> ComposeResult:
        yield Header()
        yield Static("W − B [N] per segment: waiting for a steady segment…", id="plot")
        yield Static("", id="status")
        yield RichLog(id="log", wrap=True, markup=False)
        yield Footer()

    def on_mount(self) -> None:
        self.run_worker(self._watch(), exclusive=True)

    async def _watch(self) -> None:
        try:
            await watch_link(self.link, self.trim_watch, self._record, until_s=self.until_s,
                             stop=self.stop_event)
        finally:
            await self.link.close()
        self.query_one("#status", Static).update(verdict(self.trim_watch))

    def _record(self, r: Record) -> None:
        self.records.append(r)
        log = self.query_one("#log", RichLog)
        line = format_record(r)
        log.write(Text(line, style="bold red") if isinstance(r, WatchAlert) else line)
        self._draw()

    def _draw(self) -> None:
        plot = self.query_one("#plot", Static)
        segs = [s.estimate for s in self.trim_watch.segments if s.estimate.observable[0]]
        if not segs:
            return
        xs = [(e.t_start_s + e.t_end_s) / 2 for e in segs]
        ys = [float(e.q[0]) for e in segs]
        series = [Series(xs, ys, "cyan")]
        det = self.trim_watch.detector
        if det is not None and math.isfinite(det.baseline.q[0]):
            series.append(Series([xs[0], xs[-1]], [float(det.baseline.q[0])] * 2, "green"))
        x_range = (xs[0], max(xs[-1], xs[0] + 1.0))
        width = max(20, plot.size.width - 4)
        plot.update(braille_plot(series, width=width, height=9, x_range=x_range,
                                 y_lim=y_range(ys, min_span=0.5)))
        self.query_one("#status", Static).update(
            f"{len(self.trim_watch.segments)} segments, {len(self.trim_watch.alerts)} alert(s); "
            f"latest: {format_record(self.trim_watch.segments[-1])}")

    async def action_quit_watch(self) -> None:
        self.stop_event.set()
        self.exit()
