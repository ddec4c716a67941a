"""Verdict panel: a verify hold's outcome — the residual passive trim measured against the
proposal's prediction, and per quantity measured − predicted with its ± (1σ), the ones
that differ significantly in red and named (:class:`trimd.ballast.verify.Verification`) —
or a float check's: the attitude the vehicle floats at, ± (1σ), and its verdict
(:class:`trimd.core.floating.FloatResult`)."""

from __future__ import annotations

import textwrap

from rich.text import Text
from textual.widget import Widget

from trimd.ballast.verify import Z_VERDICT, Verification
from trimd.core.floating import FloatResult, Verdict

__all__ = ["VerdictPanel", "float_lines", "verdict_lines"]

#: Short names of the compared quantities (order of trimd.ballast.verify.VERIFIED) and
#: their units.
_SHORT = (("W − B", "N"), ("W·x_g − B·x_b", "N·m"), ("W·y_g − B·y_b", "N·m"))


def verdict_lines(v: Verification, width: int = 80) -> list[Text]:
    """The panel's lines for ``v``, the advice wrapped at ``width`` columns."""
    ok_style = "bold green" if v.as_predicted else "bold red"
    head = Text("as predicted" if v.as_predicted else "NOT as predicted", style=ok_style)
    head.append("  ·  ")
    head.append("level" if v.level else f"NOT level within {v.level_tol_deg:g}°",
                style="bold green" if v.level else "bold red")
    p = v.predicted
    lines = [head, Text(f"{'trim':<6}{'measured':^14}  {'predicted':^14}", style="dim")]
    for axis, m, s, pm, ps in (("roll", v.roll_deg, v.roll_std_deg, p.roll_deg,
                                p.roll_std_deg),
                               ("pitch", v.pitch_deg, v.pitch_std_deg, p.pitch_deg,
                                p.pitch_std_deg)):
        lines.append(Text(f"{axis:<6}{m:+6.2f} ± {s:4.2f}°  {pm:+6.2f} ± {ps:4.2f}°"))
    lines.append(Text("measured − predicted (± 1σ)", style="dim"))
    off = []
    for (name, unit), d, s, z in zip(_SHORT, v.difference, v.difference_std, v.z,
                                     strict=True):
        differs = abs(z) > Z_VERDICT
        lines.append(Text(f"{name:<14}{d:+8.3f} ± {s:.3f} {unit}",
                          style="bold red" if differs else ""))
        if differs:
            off.append(name)
    if off:
        lines += [Text(line, style="bold red") for line in textwrap.wrap(
            f"{', '.join(off)} differ: check what was installed, then trim again",
            max(width, 20))]
    return lines


def float_lines(f: FloatResult, width: int = 80) -> list[Text]:
    """The panel's lines for the float check ``f``, its message wrapped at ``width``."""
    level = f.verdict is Verdict.LEVEL
    head = Text("floats level" if level else (
        f"floats NOT level within {f.level_tol_deg:g}°" if f.verdict is Verdict.NOT_LEVEL
        else "float undecided"), style="bold green" if level else "bold red")
    lines = [head, Text("passive trim, thrusters at neutral (no thrust map)", style="dim")]
    lines += [Text(f"{axis:<6}{a:+6.2f} ± {s:4.2f}°") for axis, a, s in (
        ("roll", f.roll_deg, f.roll_std_deg), ("pitch", f.pitch_deg, f.pitch_std_deg))]
    lines += [Text(line, style="dim") for line in textwrap.wrap(f.message, max(width, 20))]
    return lines


class VerdictPanel(Widget):
    """Shows the outcome of the last verify hold or float check (nothing before one)."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.verification: Verification | FloatResult | None = None
        self.border_title = "Verdict"
        self.border_subtitle = "residual trim ± 1σ"

    def show(self, v: Verification | FloatResult) -> None:
        self.verification = v
        off = (v.verdict is not Verdict.LEVEL if isinstance(v, FloatResult)
               else not v.as_predicted or not v.level)
        self.set_class(off, "-off")
        self.refresh(layout=True)

    def render(self) -> Text:
        v, width = self.verification, self.content_size.width
        if v is None:
            return Text("no verify hold or float check yet", style="dim")
        return Text("\n", no_wrap=True, overflow="ellipsis").join(
            float_lines(v, width) if isinstance(v, FloatResult) else verdict_lines(v, width))
