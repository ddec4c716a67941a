"""Shared argument reading of the commands: argparse ``type`` functions for numbers with a
range (a value outside is a one-line usage error naming the range, exit code 2, never a
traceback further on), whether the options and the terminal ask for the TUI, and the type
of the subcommand table each command's ``register`` adds its parser to."""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Sequence
from typing import TypeAlias

__all__ = ["Subcommands", "bounded", "integer", "joined_negative_weights", "wants_tui"]

#: A float's KG@WHERE (``--payload -1.2@AftSB``, ``--mass -0.5@W-aft-port``), which
#: argparse would take for an unknown option: no option's name holds an "@".
_NEGATIVE_WEIGHT = re.compile(r"^-(\d+\.?\d*|\.\d+)@")

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


def joined_negative_weights(words: Sequence[str]) -> list[str]:
    """``words`` with each ``--option -KG@WHERE`` (a float) joined into
    ``--option=-KG@WHERE``, as argparse needs it to read the value.

    Examples
    --------
    >>> joined_negative_weights(["sim", "--payload", "-1.2@AftSB", "--payload", "2@AftP"])
    ['sim', '--payload=-1.2@AftSB', '--payload', '2@AftP']
    """
    out: list[str] = []
    for word in words:
        if (_NEGATIVE_WEIGHT.match(word) and out and out[-1].startswith("--")
                and "=" not in out[-1]):
            out[-1] = f"{out[-1]}={word}"
        else:
            out.append(word)
    return out
