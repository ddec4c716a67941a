"""``trimd replay PATH``: feed a recording through the same pipeline as a live session.

* A trimd recording carries its profile; replaying it runs the same procedure over the
  recorded samples and reproduces the live estimate and proposal exactly. With a
  terminal attached (and no ``--headless`` / ``--json``) it opens the TUI, with pause
  and speed keys; the recording's own times drive the procedure at any pace.
* A foreign log (QGroundControl / MAVProxy ``.tlog``, ArduSub DataFlash ``.bin``) needs
  ``--profile``; trimd reports what the log holds (the report of ``trimd inspect``) and
  estimates from the steady attitude holds that report lists
  (:func:`trimd.app.logholds.log_holds`). A log without holds ends with why and exit
  code 1.

``--json``: only JSON lines on stdout — a recording's lines as ``trimd run --json``
prints them; for a foreign log a ``log`` line (the report) and a ``result`` line.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import sys
from pathlib import Path

from trimd.app.headless import HeadlessPresenter
from trimd.app.log_report import log_report, print_report
from trimd.app.replay import replay_profile, replay_session
from trimd.app.report import format_result
from trimd.ballast.propose import METHODS, propose_ballast
from trimd.cli.argtypes import Subcommands, bounded, wants_tui
from trimd.core.errors import DataError, EstimationError, NoResultError
from trimd.core.estimate import estimate_static
from trimd.core.events import Phase
from trimd.core.procedure import VERIFY_DONE
from trimd.core.profile import Profile
from trimd.logs.replay import recorded_trimd_texts, recorded_verify_target

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "replay", help="replay a recorded session or analyse a vehicle log",
        description="Replay a trimd recording through the procedure (same result as live), "
        "or find steady attitude holds in a foreign .tlog / DataFlash .bin log.")
    p.add_argument("path", help="a .tlog or DataFlash .bin file")
    p.add_argument("--profile", help="vehicle profile (a trimd recording carries its own)")
    pace = p.add_mutually_exclusive_group()
    pace.add_argument("--speed", type=bounded(0.0), help="pace at this many times real time (> 0)")
    pace.add_argument("--fast", action="store_true", help="as fast as possible (the default "
                      "headless; the TUI starts at real time)")
    p.add_argument("--headless", action="store_true", help="no terminal UI")
    p.add_argument("--json", action="store_true", help="headless, one JSON object per line")
    p.add_argument("--ballast", choices=METHODS, default="milp", help="ballast method")
    p.set_defaults(func=run)


def _analyse_foreign(path: str, profile: Profile, args: argparse.Namespace) -> int:
    """The log's report, then the estimate and proposal from the holds it lists (the
    same presenter as a recording's result); NoResultError when it lists none."""
    report, found = log_report(path, profile)
    print_report(report, args.json)
    if not found:
        raise NoResultError(f"cannot estimate from this log: {report['no_holds_because']}")
    try:
        est = estimate_static([h.samples for h in found], profile)
    except EstimationError as exc:
        raise NoResultError(f"cannot estimate from this log: {exc}") from None
    HeadlessPresenter(json_lines=args.json).result(
        est, propose_ballast(est, profile, method=args.ballast))
    return 0


def run(args: argparse.Namespace) -> int:
    path = str(args.path)
    if not Path(path).is_file():
        raise DataError(f"{path}: no such file")
    profile, recording = replay_profile(path, args.profile)
    if not recording:
        return _analyse_foreign(path, profile, args)
    if wants_tui(args):
        from trimd.tui.replay_app import replay_app  # Textual only for the TUI
        from trimd.tui.run import run_in_tui

        app = replay_app(path, profile, speed=math.inf if args.fast else args.speed or 1.0,
                         method=args.ballast)
        result = asyncio.run(run_in_tui(app))
        warnings = app.replay.link.warnings if app.replay else []
        text = format_result(result)
        if text:
            print(text)
    else:
        presenter = HeadlessPresenter(json_lines=args.json)
        result, link = asyncio.run(replay_session(
            path, profile, speed=args.speed, presenters=[presenter], method=args.ballast))
        warnings = link.warnings
    for warning in warnings:
        print(f"trimd: warning: {warning}", file=sys.stderr)
    if result.phase is not Phase.DONE:
        print(f"trimd: replay ended {result.phase.value}: {result.reason}", file=sys.stderr)
        if recorded_verify_target(path) is None and VERIFY_DONE in recorded_trimd_texts(path):
            print(f"trimd: {path} is a verify hold recorded by an older trimd, without the "
                  "trim it verified: it replays only as a trim, which it is not (its verdict "
                  "is in the trim history: trimd history)", file=sys.stderr)
        return 1
    return 0
