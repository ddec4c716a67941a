"""A line plot in braille characters (2 × 4 dots per cell), drawn into rich Text.

Small and dependency-free: the attitude panel needs a few lines over the last minute,
not a plotting library.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from rich.style import Style
from rich.text import Text

__all__ = ["Series", "braille_plot", "y_range"]

# bit of each dot in a braille cell, indexed [row][column]
_DOTS = ((0x01, 0x08), (0x02, 0x10), (0x04, 0x20), (0x40, 0x80))
_LABEL_W = 6


@dataclass(frozen=True)
class Series:
    """Points to join with a line (NaN breaks it), drawn in ``style``."""

    xs: Sequence[float]
    ys: Sequence[float]
    style: str


def y_range(values: Sequence[float], *, min_span: float) -> tuple[float, float]:
    """A range around the finite ``values``, at least ``min_span`` wide, padded 10 %.

    >>> y_range([0.0, 20.0], min_span=2.0)
    (-2.0, 22.0)
    """
    finite = [v for v in values if math.isfinite(v)]
    lo, hi = (min(finite), max(finite)) if finite else (0.0, 0.0)
    if hi - lo < min_span:
        mid = (hi + lo) / 2
        lo, hi = mid - min_span / 2, mid + min_span / 2
    pad = 0.1 * (hi - lo)
    return lo - pad, hi + pad


def braille_plot(series: Sequence[Series], *, width: int, height: int,
                 x_range: tuple[float, float], y_lim: tuple[float, float]) -> Text:
    """``height`` lines of ``width`` cells: y labels on the left, then the plot.

    ``y_lim`` is (bottom, top): give it reversed (bottom > top) for a quantity that grows
    downwards, such as depth.
    """
    cols, rows = max(1, width - _LABEL_W), max(1, height)
    bits = [[0] * cols for _ in range(rows)]
    colour: list[list[str | None]] = [[None] * cols for _ in range(rows)]
    (x0, x1), (y0, y1) = x_range, y_lim
    sx = (2 * cols - 1) / (x1 - x0) if x1 > x0 else 0.0
    sy = (4 * rows - 1) / (y1 - y0) if y1 != y0 else 0.0

    def dot(px: int, py: int, style: str) -> None:
        if 0 <= px < 2 * cols and 0 <= py < 4 * rows:
            r, c = py // 4, px // 2
            bits[r][c] |= _DOTS[py % 4][px % 2]
            colour[r][c] = style

    for s in series:
        prev: tuple[float, float] | None = None
        for x, y in zip(s.xs, s.ys, strict=True):
            if not (math.isfinite(x) and math.isfinite(y)):
                prev = None
                continue
            p = ((x - x0) * sx, (y1 - y) * sy)
            a = prev or p
            n = max(1, round(max(abs(p[0] - a[0]), abs(p[1] - a[1]))))  # a dot per step
            for k in range(n + 1):
                f = k / n
                dot(round(a[0] + f * (p[0] - a[0])), round(a[1] + f * (p[1] - a[1])), s.style)
            prev = p
    out = Text(no_wrap=True, overflow="crop")
    for r in range(rows):
        if r == 0 or r == rows - 1:
            label = f"{(y1 if r == 0 else y0):>{_LABEL_W - 1}.1f}"
        else:
            label = " " * (_LABEL_W - 1)
        out.append(label + "│", style="dim")
        for c in range(cols):
            style = colour[r][c]
            out.append(chr(0x2800 + bits[r][c]), Style.parse(style) if style else None)
        if r < rows - 1:
            out.append("\n")
    return out
