"""``trimd float --link URL --profile P``: the float check (:mod:`trimd.app.float_check`,
docs/method.md §8): trimd lets go of the vehicle (thrusters at neutral, open loop) and
measures the attitude it floats at, its passive trim, with no thrust map; it prints the
attitude ± (95 %) and the verdict. Headless; recorded like every session, and ``trimd
replay LOG`` reproduces the result.

With ``--correct [TRIM.json]`` (the trim whose ballast is on: a trim's or correction's
result, or alone the vehicle's last trim in the history) a float that is not level ends
with the correction of the ballast installed now, from the attitude it floated at
(:func:`trimd.ballast.correct.floated_vehicle`), as ``trimd run --verify`` prints one.
The float check is stored in the trim history with its correction linked to it (a later
``trimd run --verify`` or ``trimd float --correct`` checks that correction once ``trimd
ballast apply`` records it as installed); ``--no-history`` neither reads nor stores.

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
from trimd.app.float_check import (
    FloatRequest,
    float_correction,
    run_float_check,
    store_float_check,
)
from trimd.app.headless import HeadlessPresenter
from trimd.app.jsonlines import print_result
from trimd.app.report import format_correction
from trimd.app.verify import trim_target
from trimd.ballast.correct import correction_to_dict
from trimd.cli.argtypes import Subcommands, bounded
from trimd.cli.history_args import add_history_args, db_path, vehicle_of
from trimd.core.errors import ProfileError, TrimdError
from trimd.core.events import Phase
from trimd.core.floating import Verdict
from trimd.core.profile_yaml import load_profile

__all__ = ["register", "run"]

#: ``--correct`` without a file: the vehicle's last trim in the history.
_LAST_TRIM = "last"


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
    p.add_argument("--correct", metavar="TRIM.json", nargs="?", const=_LAST_TRIM,
                   help="when it does not float level, propose the correction of the "
                   "ballast installed now for the trim in TRIM.json (a trim's or "
                   "correction's result) or, alone, the vehicle's last trim in the history")
    p.add_argument("--no-history", action="store_true", help="neither read the installed "
                   "ballast from the trim history (the profile's is used) nor store the "
                   "float check in it")
    add_history_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    if not args.yes and not sys.stdin.isatty():
        raise ProfileError("headless without a terminal cannot ask for confirmation: "
                           "pass --yes to let trimd let go of the vehicle")
    vehicle, db = vehicle_of(args, profile.name), None if args.no_history else db_path(args)
    # the trim is read before the link opens: bad input commands nothing
    target = None if args.correct is None else trim_target(
        None if args.correct == _LAST_TRIM else args.correct, profile, db, vehicle)
    record = None
    if not args.no_record:
        record = Path(args.record) if args.record else default_record_path(profile)
    request = FloatRequest(args.profile, confirmed=args.yes,
                           depth_excursion_m=args.max_depth_excursion, record=record,
                           for_correction=target is not None)
    result = asyncio.run(run_float_check(lambda: open_link(args.link, profile), profile,
                                         request, [HeadlessPresenter(json_lines=args.json)]))
    if result.phase is not Phase.DONE:
        print(f"trimd float: {result.phase.value}: {result.reason}", file=sys.stderr)
    if result.log_path:
        print(f"session log: {result.log_path}", file=sys.stderr)
    if result.cause == "link":
        return 3
    f = result.verification
    correction = None
    if f is not None and target is not None:
        try:
            correction = float_correction(f, target, profile, db, vehicle)
        except TrimdError as exc:
            print(f"trimd float: warning: no correction proposed: {exc}", file=sys.stderr)
        else:
            if correction is not None:
                print_result(args.json, {"type": "correction",
                                         **correction_to_dict(correction)},
                             "\n" + format_correction(correction, "the float check"))
    if f is not None and db is not None:
        try:
            stored = store_float_check(db, vehicle, profile, result, correction)
        except TrimdError as exc:  # the float itself succeeded and was printed
            print(f"trimd float: warning: not stored in the trim history: {exc}",
                  file=sys.stderr)
        else:
            if stored:
                print(stored, file=sys.stderr)
    return 0 if f is not None and f.verdict is Verdict.LEVEL else 1
