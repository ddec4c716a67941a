"""Thruster panel: each thruster's effort as a bar centred on zero, saturation in red.

Effort is the thrust of the present output as a fraction of the most that thruster
gives in that direction, both from the profile's thrust curve (``trimd.core.model``) at the
battery voltage last reported.
"""

from __future__ import annotations

import math

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

from trimd.core.model import thrust_from_pwm
from trimd.core.profile import Profile
from trimd.tui.telemetry import LiveState

__all__ = ["SATURATED", "ThrusterPanel", "efforts"]

#: At or beyond this fraction of the available thrust a thruster counts as saturated.
SATURATED = 0.98
_WARN = 0.8
#: PWM far beyond any table [µs]: the thrust curve saturates at its ends.
_PWM_EXTREMES = (0.0, 1.0e5)


def efforts(profile: Profile, pwm_us: tuple[float, ...], voltage_V: float) -> list[float]:
    """Per-thruster thrust as a signed fraction of the most available that way."""
    out = []
    for th, pwm in zip(profile.thrusters, pwm_us, strict=True):
        f, lo, hi = thrust_from_pwm(th.curve, [pwm, *_PWM_EXTREMES], voltage_V)
        out.append(float(f / hi) if f >= 0 else float(f / -lo))
    return out


def _bar(effort: float, half: int) -> Text:
    """A bar ``2·half + 1`` cells wide: negative efforts grow left of the centre."""
    n = min(half, round(abs(effort) * half))
    style = ("bold white on red" if abs(effort) >= SATURATED
             else "yellow" if abs(effort) >= _WARN else "green")
    text = Text()
    if effort < 0:
        text.append("·" * (half - n), style="dim")
        text.append("█" * n, style=style)
        text.append("│" + "·" * half, style="dim")
    else:
        text.append("·" * half + "│", style="dim")
        text.append("█" * n, style=style)
        text.append("·" * (half - n), style="dim")
    return text


class ThrusterPanel(Widget):
    """Redrawn whenever ``t_s`` (the latest thruster sample time) changes."""

    t_s: reactive[float] = reactive(math.nan)

    def __init__(self, state: LiveState, profile: Profile, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.state = state
        self.profile = profile
        self.border_title = "Thrusters"

    def render(self) -> Text:
        names = [t.name for t in self.profile.thrusters]
        thr = self.state.thrusters
        voltage = (self.state.battery.voltage_V if self.state.battery
                   else self.profile.nominal_voltage_V)
        values = (efforts(self.profile, thr.pwm_us, voltage)
                  if thr and len(thr.pwm_us) == len(names) else None)
        name_w = min(14, max(len(n) for n in names))
        half = max(2, (self.content_size.width - name_w - 11) // 2)
        text = Text(no_wrap=True, overflow="crop")
        for i, name in enumerate(names):
            text.append(f"{name[:name_w]:<{name_w}} ")
            if values is None:
                text.append("no data", style="dim")
            else:
                e = values[i]
                text.append_text(_bar(e, half))
                text.append(f" {e:+5.0%}", style="bold red" if abs(e) >= SATURATED else "")
                if abs(e) >= SATURATED:
                    text.append(" SAT", style="bold red")
            if i < len(names) - 1:
                text.append("\n")
        return text
