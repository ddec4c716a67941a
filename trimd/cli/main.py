"""The ``trimd`` command: one sub-command per module of :mod:`trimd.cli`.

Each command module exposes ``register(subparsers)`` which adds its parser and sets
``func`` to a ``run(args) -> int``. Every error a user can cause — a bad argument
(:class:`UsageError`, argparse's own included), a file, profile or log trimd cannot use
(TrimdError, OSError), a link that fails, an interrupt — ends the same way, never with a
traceback: one line on stderr, and with ``--json`` also an ``error`` line on stdout
carrying that line and the exit code (docs/operator.md, "JSON output"). Exit codes: 1 no
result or interrupted, 2 usage, profile and data errors, 3 link errors.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import NoReturn

from trimd import __version__
from trimd.app.jsonlines import error_line, print_json
from trimd.cli import (
    ballast,
    calibrate,
    float_check,
    history,
    identify,
    inspect,
    replay,
    run,
    serve,
    sim,
    solve,
    watch,
)
from trimd.cli.argtypes import joined_negative_weights
from trimd.core.errors import LinkError, NoResultError, TrimdError, UsageError

__all__ = ["main"]

#: Modules that provide sub-commands, in the order ``trimd --help`` lists them.
COMMANDS = (run, float_check, watch, serve, replay, solve, ballast, calibrate, history, sim,
            inspect, identify)


class _Parser(argparse.ArgumentParser):
    """argparse's parser, raising its usage errors (as :class:`UsageError`) instead of
    printing them, so that :func:`main` reports every error one way."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(message, self.prog, self.format_usage())


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="trimd", description="Trim assistant for underwater vehicles: measure the "
        "centre of gravity and extra mass, propose ballast.")
    parser.add_argument("--version", action="version", version=f"trimd {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.register(sub)
    return parser


def _error_text(exc: BaseException) -> tuple[str, int]:
    """The line for stderr and the exit code of an error that ends a command."""
    if isinstance(exc, UsageError):
        return f"{exc.prog}: error: {exc}", 2
    if isinstance(exc, LinkError):
        return f"trimd: link error: {exc}", 3
    if isinstance(exc, NoResultError):
        return f"trimd: {exc}", 1
    if isinstance(exc, TrimdError):
        return f"trimd: error: {exc}", 2
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return f"trimd: error: {where}{exc.strerror or exc}", 2
    return "trimd: interrupted", 1


def _fail(exc: BaseException, as_json: bool) -> int:
    text, code = _error_text(exc)
    if isinstance(exc, UsageError) and exc.usage:
        sys.stderr.write(exc.usage)
    print(text, file=sys.stderr)
    if as_json:
        print_json(error_line(text, code))
    return code


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the process exit code."""
    words = joined_negative_weights(sys.argv[1:] if argv is None else argv)
    as_json = "--json" in words  # until the arguments are parsed (a usage error)
    try:
        args = build_parser().parse_args(words)
        as_json = bool(getattr(args, "json", False))
        code: int = args.func(args)
    except BrokenPipeError:  # the reader went away (``| head``): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (TrimdError, OSError, KeyboardInterrupt) as exc:
        return _fail(exc, as_json)
    return code


if __name__ == "__main__":
    sys.exit(main())
