"""``trimd inspect LOG [--profile P] [--json]``: what a vehicle log holds (the report:
:mod:`trimd.app.log_report`). Exit 0 for a readable log (holds or not); an unreadable or
empty log is a DataError (exit 2).
"""

from __future__ import annotations

import argparse

from trimd.cli.argtypes import Subcommands
from trimd.core.profile_yaml import load_profile

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "inspect", help="report what a vehicle log (.tlog or DataFlash .BIN) holds",
        description="Report a log's format, duration, vehicle, frame, streams and rates, "
        "modes, armed periods, bad frames, attitude range and steady attitude holds.")
    p.add_argument("log", help="a MAVLink .tlog or an ArduSub DataFlash .BIN")
    p.add_argument("--profile", help="vehicle profile (thruster channels, tolerances)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from trimd.app.log_report import inspect_log, print_report  # pymavlink: 0.3 s

    profile = load_profile(args.profile) if args.profile else None
    print_report(inspect_log(args.log, profile), args.json)
    return 0
