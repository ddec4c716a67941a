"""The ``trimd`` command: one sub-command per module of :mod:`trimd.cli`.

Each command module exposes ``register(subparsers)`` which adds its parser and sets
``func`` to a ``run(args) -> int``. User errors (TrimdError) become one line on stderr
and an exit code: 2 for usage, profile and data errors, 3 for link errors.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from trimd import __version__
from trimd.cli import ballast, history, identify, inspect, replay, run, sim, solve, watch
from trimd.core.errors import LinkError, TrimdError

__all__ = ["main"]

#: Modules that provide sub-commands, in the order ``trimd --help`` lists them.
COMMANDS = (run, watch, replay, solve, ballast, history, sim, inspect, identify)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="trimd", description="Trim assistant for underwater vehicles: measure the "
        "centre of gravity and extra mass, propose ballast.")
    parser.add_argument("--version", action="version", version=f"trimd {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code: int = args.func(args)
    except LinkError as exc:
        print(f"trimd: link error: {exc}", file=sys.stderr)
        return 3
    except TrimdError as exc:
        print(f"trimd: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("trimd: interrupted", file=sys.stderr)
        return 1
    return code


if __name__ == "__main__":
    sys.exit(main())
