"""The vehicle seen from above, in terminal cells: outline, thrusters, ballast slots
(lettered, coloured by what the proposal puts there), CG0 and the arrow to CG1.

Body frame FRD: forward (x) is up the screen, starboard (y) to the right. A centre of
gravity moves by millimetres on a vehicle of metres, so the arrow is drawn magnified
by a round factor that the legend states.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from rich.text import Text

from trimd.core.profile import Profile

__all__ = ["SLOT_LETTERS", "top_view"]

SLOT_LETTERS = "ABCDEFGHIJKLMNOPQRSTUVWXYZ"
WEIGHT, FLOAT, BOTH, EMPTY = "bold yellow", "bold cyan", "bold green", "dim"


def _nice(x: float) -> float:
    """The largest of 1, 2, 5 × 10^k not above ``x``."""
    p = 10.0 ** math.floor(math.log10(x))
    return max(m * p for m in (1, 2, 5) if m * p <= x)


def top_view(profile: Profile, *, width: int, height: int,
             cg_m: tuple[float, float] | None = None,
             slot_styles: Sequence[str] | None = None) -> Text:
    """``height`` lines of ``width`` cells; ``slot_styles`` per slot (default: empty)."""
    points = [t.position_m for t in profile.thrusters] + [s.position_m for s in profile.slots]
    x_half = 1.15 * max(abs(p[0]) for p in points) or 1.0
    y_half = 1.15 * max(abs(p[1]) for p in points) or 1.0
    # odd sizes put CG0 on a cell's centre
    rows, cols = max(3, height - 1 - (height % 2)), max(5, width - (width % 2 == 0))
    # cells are about twice as tall as wide: one row spans as many metres as two columns
    per_col = max(2 * y_half / (cols - 1), x_half / (rows - 1))
    grid = [[(" ", "")] * cols for _ in range(rows)]

    def cell(x: float, y: float) -> tuple[int, int]:
        return (round((rows - 1) / 2 - x / (2 * per_col)),
                round((cols - 1) / 2 + y / per_col))

    def put(r: int, c: int, ch: str, style: str = "") -> None:
        if 0 <= r < rows and 0 <= c < cols:
            grid[r][c] = (ch, style)

    top, left = cell(x_half, -y_half)
    bottom, right = cell(-x_half, y_half)
    for c in range(left, right + 1):
        put(top, c, "─", "dim")
        put(bottom, c, "─", "dim")
    for r in range(top, bottom + 1):
        put(r, left, "│", "dim")
        put(r, right, "│", "dim")
    for (r, c), ch in zip(((top, left), (top, right), (bottom, left), (bottom, right)), "╭╮╰╯",
                          strict=True):
        put(r, c, ch, "dim")
    put(top, (left + right) // 2, "▲", "bold")
    for t in profile.thrusters:
        put(*cell(t.position_m[0], t.position_m[1]), "⊗", "dim")
    for i, s in enumerate(profile.slots):
        style = slot_styles[i] if slot_styles else EMPTY
        put(*cell(s.position_m[0], s.position_m[1]), SLOT_LETTERS[i % 26], style)
    legend = "+ CG0"
    if cg_m is not None:
        shift = math.hypot(*cg_m)
        gain = _nice(min(x_half, y_half) / shift) if shift > 0 else 1.0
        (r0, c0), (r1, c1) = cell(0.0, 0.0), cell(gain * cg_m[0], gain * cg_m[1])
        n = max(abs(r1 - r0), abs(c1 - c0))
        for k in range(1, n):
            put(round(r0 + k * (r1 - r0) / n), round(c0 + k * (c1 - c0) / n), "·", "bold red")
        put(r1, c1, "●", "bold red")
        legend += f"  ● CG1 (shift ×{gain:g})"
    put(*cell(0.0, 0.0), "+", "bold")
    text = Text(no_wrap=True, overflow="crop")
    for row in grid:
        for ch, style in row:
            text.append(ch, style=style or None)
        text.append("\n")
    text.append(legend, style="dim")
    return text
