"""Attitude panel: roll, pitch, yaw and depth against their set-points, and a braille
plot of roll and pitch over the last minute of sample time (its legend in the border)."""

from __future__ import annotations

import math

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

from trimd.tui.plot import Series, braille_plot, y_range
from trimd.tui.telemetry import HISTORY_S, LiveState

__all__ = ["AttitudePanel"]

_ROLL, _PITCH, _SET = "bold cyan", "bold magenta", "dim white"


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
        self.border_subtitle = (f"[{_ROLL}]━ roll[/] [{_PITCH}]━ pitch[/] [{_SET}]━ set[/]"
                                f" · last {HISTORY_S:.0f} s")

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
        height = self.content_size.height - 3
        if height >= 2:
            text.append_text(self._plot(self.content_size.width, height))
        return text

    def _plot(self, width: int, height: int) -> Text:
        h, sp = self.state.history, self.state.setpoint
        t_end = h[-1].t_s if h else 0.0
        ts = [p.t_s for p in h]
        series = [Series(ts, [p.roll_deg for p in h], _ROLL),
                  Series(ts, [p.pitch_deg for p in h], _PITCH)]
        values = [v for s in series for v in s.ys]
        if sp is not None:
            ends = [t_end - HISTORY_S, t_end]
            series[:0] = [Series(ends, [sp.roll_deg] * 2, _SET),
                          Series(ends, [sp.pitch_deg] * 2, _SET)]
            values += [sp.roll_deg, sp.pitch_deg]
        return braille_plot(series, width=width, height=height,
                            x_range=(t_end - HISTORY_S, t_end), y_lim=y_range(values, min_span=2.0))
