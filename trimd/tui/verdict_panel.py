"""Verdict panel: a verify hold's outcome — the residual passive trim measured against the
proposal's prediction, and per quantity measured − predicted with its ± (1σ), the ones
that differ significantly in red and named (:class:`trimd.ballast.verify.Verification`)."""

from __future__ import annotations

from rich.text import Text
from textual.widget import Widget

from trimd.ballast.verify import VERIFIED, Z_VERDICT, Verification

__all__ = ["VerdictPanel", "verdict_lines"]

#: Short names of the compared quantities (order of VERIFIED) and their units.
_SHORT = (("W − B", "N"), ("W·x_g − B·x_b", "N·m"), ("W·y_g − B·y_b", "N·m"))


def verdict_lines(v: Verification) -> list[Text]:
    """The panel's lines for ``v``."""
    ok_style = "bold green" if v.as_predicted else "bold red"
    head = Text("as predicted" if v.as_predicted else "NOT as predicted", style=ok_style)
    head.append("  ·  ")
    head.append("level" if v.level else f"NOT level within {v.level_tol_deg:g}°",
                style="bold green" if v.level else "bold red")
    p = v.predicted
    lines = [head, Text("residual trim  measured       predicted", style="dim")]
    for axis, m, s, pm, ps in (("roll", v.roll_deg, v.roll_std_deg, p.roll_deg,
                                p.roll_std_deg),
                               ("pitch", v.pitch_deg, v.pitch_std_deg, p.pitch_deg,
                                p.pitch_std_deg)):
        lines.append(Text(f"  {axis:<6}{m:+7.2f} ± {s:4.2f}°  {pm:+7.2f} ± {ps:4.2f}°"))
    lines.append(Text("measured − predicted (± 1σ)", style="dim"))
    off = []
    for (name, unit), full, d, s, z in zip(_SHORT, VERIFIED, v.difference,
                                           v.difference_std, v.z, strict=True):
        differs = abs(z) > Z_VERDICT
        lines.append(Text(f"  {name:<14}{d:+8.3f} ± {s:.3f} {unit}",
                          style="bold red" if differs else ""))
        if differs:
            off.append(full.split(" [")[0])
    if off:
        lines.append(Text(f"differs: {'; '.join(off)}: check what was installed, then "
                          "trim again", style="bold red"))
    return lines


class VerdictPanel(Widget):
    """Shows the verification of the last verify hold (nothing before one)."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.verification: Verification | None = None
        self.border_title = "Verify hold"

    def show(self, v: Verification) -> None:
        self.verification = v
        self.set_class(not v.as_predicted or not v.level, "-off")
        self.refresh(layout=True)

    def render(self) -> Text:
        if self.verification is None:
            return Text("no verify hold yet", style="dim")
        return Text("\n").join(verdict_lines(self.verification))
