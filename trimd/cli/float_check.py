"""``trimd float --link URL --profile P``: the float check (:mod:`trimd.app.float_check`,
docs/method.md §8): trimd lets go of the vehicle (thrusters at neutral, open loop) and
measures the attitude it floats at, its passive trim, with no thrust map; it prints the
attitude ± (95 %) and the verdict. Headless; recorded like every session, and ``trimd
replay LOG`` reproduces the result.

Exit codes: 0 level within the profile's tolerance, 1 not level, undecided, failed or
aborted, 2 usage or profile error, 3 link error (cannot open, or lost during the float).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from pathlib import Path

from trimd.app.connect import open_link
from trimd.app.files import default_record_path
from trimd.app.float_check import FloatRequest, run_float_check
from trimd.app.headless import HeadlessPresenter
from trimd.cli.argtypes import Subcommands, bounded
from trimd.core.errors import ProfileError
from trimd.core.events import Phase
from trimd.core.floating import FloatResult, Verdict
from trimd.core.profile_yaml import load_profile

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "float", help="let go of the vehicle and measure how it floats",
        description="The float check: trimd sets every thruster to neutral (open loop, no "
        "input), waits for roll and pitch to settle and measures the attitude the vehicle "
        "floats at: its passive trim, to the attitude reference's accuracy, with no "
        "thrust map. Use it after installing ballast, instead of or after a verify hold "
        "(docs/operator.md). It releases the vehicle when the depth moves 80 %% of the "
        "allowed change, beyond the tilt limit, on link loss, pilot input or abort.")
    p.add_argument("--link", required=True, help="sim[:opts] | mavlink:<conn> | "
                   "serial:<dev>[,baud] | replay:<path>")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--yes", action="store_true", help="confirm up front: trimd may let go of "
                   "the vehicle without asking")
    p.add_argument("--json", action="store_true", help="one JSON object per line")
    p.add_argument("--max-depth-excursion", type=bounded(0.0), metavar="M",
                   help="largest depth change from the start [m], > 0 (default: the "
                   "profile's max_depth_excursion_m); the float stops at 80 %% of it")
    record = p.add_mutually_exclusive_group()
    record.add_argument("--record", metavar="PATH", help="session log (default: a "
                        "timestamped file in the data directory's sessions/)")
    record.add_argument("--no-record", action="store_true", help="do not write a session log")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    if not args.yes and not sys.stdin.isatty():
        raise ProfileError("headless without a terminal cannot ask for confirmation: "
                           "pass --yes to let trimd let go of the vehicle")
    record = None
    if not args.no_record:
        record = Path(args.record) if args.record else default_record_path(profile)
    request = FloatRequest(args.profile, confirmed=args.yes,
                           depth_excursion_m=args.max_depth_excursion, record=record)
    result = asyncio.run(run_float_check(lambda: open_link(args.link, profile), profile,
                                         request, [HeadlessPresenter(json_lines=args.json)]))
    if result.phase is not Phase.DONE:
        print(f"trimd float: {result.phase.value}: {result.reason}", file=sys.stderr)
    if result.log_path:
        print(f"session log: {result.log_path}", file=sys.stderr)
    if result.cause == "link":
        return 3
    level = (isinstance(result.verification, FloatResult)
             and result.verification.verdict is Verdict.LEVEL)
    return 0 if level else 1
