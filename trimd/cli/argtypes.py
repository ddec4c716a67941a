"""Shared argument reading of the commands: argparse ``type`` functions for numbers with a
range (a value outside is a one-line usage error naming the range, exit code 2, never a
traceback further on), whether the options and the terminal ask for the TUI, and the type
of the subcommand table each command's ``register`` adds its parser to."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import TypeAlias

__all__ = ["Subcommands", "bounded", "integer", "wants_tui"]

#: What ``ArgumentParser.add_subparsers`` returns: each command module's ``register`` adds
#: its parser to it.
Subcommands: TypeAlias = "argparse._SubParsersAction[argparse.ArgumentParser]"


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


def integer(low: int, high: int | None = None) -> Callable[[str], int]:
    """An argparse ``type``: a whole number ≥ ``low`` (and ≤ ``high`` when given)."""
    wanted = f"≥ {low}" if high is None else f"in {low}…{high}"

    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            n = low - 1
        if n < low or (high is not None and n > high):
            raise argparse.ArgumentTypeError(f"expected an integer {wanted}, got '{text}'")
        return n

    return parse


def wants_tui(args: argparse.Namespace) -> bool:
    """The TUI, unless ``--headless`` or ``--json`` or no terminal is attached."""
    return not args.headless and not args.json and sys.stdin.isatty() and sys.stdout.isatty()
