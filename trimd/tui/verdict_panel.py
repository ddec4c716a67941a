"""Verdict panel: a verify hold's outcome — the residual passive trim measured against the
proposal's prediction, and per quantity measured − predicted with its ± (1σ), the ones
that differ significantly in red and named (:class:`trimd.ballast.verify.Verification`)."""

from __future__ import annotations

import textwrap

from rich.text import Text
from textual.widget import Widget

from trimd.ballast.verify import Z_VERDICT, Verification

__all__ = ["VerdictPanel", "verdict_lines"]

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


class VerdictPanel(Widget):
    """Shows the verification of the last verify hold (nothing before one)."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.verification: Verification | None = None
        self.border_title = "Verdict"
        self.border_subtitle = "residual trim ± 1σ"

    def show(self, v: Verification) -> None:
        self.verification = v
        self.set_class(not v.as_predicted or not v.level, "-off")
        self.refresh(layout=True)

    def render(self) -> Text:
        if self.verification is None:
            return Text("no verify hold yet", style="dim")
        return Text("\n", no_wrap=True, overflow="ellipsis").join(
            verdict_lines(self.verification, self.content_size.width))
