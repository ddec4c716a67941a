"""argparse ``type`` functions for numbers with a range: a value outside is a one-line
usage error naming the range (exit code 2), never a traceback further on."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = ["bounded", "whole_number"]


def bounded(low: float, high: float = math.inf) -> Callable[[str], float]:
    """An argparse ``type``: a finite number above ``low`` and at most ``high``; anything
    else is a usage error naming the interval."""
    interval = f"({low:g}, {high:g}]" if math.isfinite(high) else f"({low:g}, ∞)"

    def parse(text: str) -> float:
        try:
            x = float(text)
        except ValueError:
            x = math.nan
        if not (math.isfinite(x) and low < x <= high):
            raise argparse.ArgumentTypeError(f"expected a number in {interval}, got '{text}'")
        return x

    return parse


def whole_number(text: str) -> int:
    """An argparse ``type``: a non-negative integer (e.g. a random seed)."""
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 0:
        raise argparse.ArgumentTypeError(f"expected an integer ≥ 0, got '{text}'")
    return n
