"""Attitude panel: roll, pitch, yaw and depth against their set-points, and braille plots
over the last minute of sample time: roll and pitch (their legend in the border) and,
when the panel is tall enough, depth below it. Yaw is numbers only: the vehicle holds
its heading itself, and trimd commands the heading it found."""

from __future__ import annotations

import math

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

from trimd.tui.plot import Series, braille_plot, y_range
from trimd.tui.telemetry import HISTORY_S, LiveState

__all__ = ["AttitudePanel"]

_ROLL, _PITCH, _SET, _DEPTH = "bold cyan", "bold magenta", "dim white", "bold yellow"
#: Plot rows [lines] from which a depth plot (a third of them) goes below roll and pitch.
_DEPTH_PLOT_FROM = 6
#: Lines above the plots: the table's heading, now and set.
_TABLE_H = 3


def _cells(values: tuple[float | None, ...]) -> str:
    return "".join("      —" if v is None or math.isnan(v) else f"{v:7.2f}" for v in values)


class AttitudePanel(Widget):
    """Redrawn whenever ``t_s`` (the latest sample time) changes."""

    t_s: reactive[float] = reactive(math.nan)

    def __init__(self, state: LiveState, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.state = state
        self.border_title = "Attitude"
        # the plot's legend (the table's headings are coloured the same)
        self._legend(with_depth=False)

    def _legend(self, *, with_depth: bool) -> None:
        depth = f" [{_DEPTH}]━ depth[/]" if with_depth else ""
        self.border_subtitle = (f"[{_ROLL}]━ roll[/] [{_PITCH}]━ pitch[/] [{_SET}]━ set[/]"
                                f"{depth} · last {HISTORY_S:.0f} s")

    def on_resize(self) -> None:
        self._legend(with_depth=self.content_size.height - _TABLE_H >= _DEPTH_PLOT_FROM)

    def render(self) -> Text:
        s, a, sp = self.state, self.state.attitude, self.state.setpoint
        deg = (None, None, None) if a is None else tuple(math.degrees(v)
                                                         for v in (a.phi, a.theta, a.psi))
        text = Text(no_wrap=True, overflow="crop")
        text.append("°, m ", style="dim")
        text.append("   roll", style=_ROLL)
        text.append("  pitch", style=_PITCH)
        text.append("    yaw  depth\n")
        depth = None if s.depth is None else s.depth.depth_m
        text.append("now  " + _cells((*deg, depth)) + "\n")
        text.append("set  " + (_cells((sp.roll_deg, sp.pitch_deg, sp.yaw_deg, sp.depth_m))
                                   if sp else "  released") + "\n", style="dim")
        height, width = self.content_size.height - _TABLE_H, self.content_size.width
        if height >= _DEPTH_PLOT_FROM:
            depth_h = height // 3
            text.append_text(self._plot(width, height - depth_h)).append("\n")
            text.append_text(self._depth_plot(width, depth_h))
        elif height >= 2:
            text.append_text(self._plot(width, height))
        return text

    def _window(self) -> tuple[float, float]:
        h = self.state.history
        t_end = h[-1].t_s if h else 0.0
        return t_end - HISTORY_S, t_end

    def _plot(self, width: int, height: int) -> Text:
        """Roll and pitch [deg] and their set-points."""
        h, sp = self.state.history, self.state.setpoint
        ts = [p.t_s for p in h]
        series = [Series(ts, [p.roll_deg for p in h], _ROLL),
                  Series(ts, [p.pitch_deg for p in h], _PITCH)]
        values = [v for s in series for v in s.ys]
        if sp is not None:
            series[:0] = [Series(self._window(), [sp.roll_deg] * 2, _SET),
                          Series(self._window(), [sp.pitch_deg] * 2, _SET)]
            values += [sp.roll_deg, sp.pitch_deg]
        return braille_plot(series, width=width, height=height, x_range=self._window(),
                            y_lim=y_range(values, min_span=2.0))

    def _depth_plot(self, width: int, height: int) -> Text:
        """Depth [m] and the depth held, deeper lower down (the y axis reversed)."""
        h, sp = self.state.history, self.state.setpoint
        series = [Series([p.t_s for p in h], [p.depth_m for p in h], _DEPTH)]
        values = list(series[0].ys)
        if sp is not None and math.isfinite(sp.depth_m):
            series.insert(0, Series(self._window(), [sp.depth_m] * 2, _SET))
            values.append(sp.depth_m)
        shallow, deep = y_range(values, min_span=0.2)
        return braille_plot(series, width=width, height=height, x_range=self._window(),
                            y_lim=(deep, shallow))
