"""``trimd calibrate --link URL --profile P --mass KG@SLOT``: a deliberate calibration of
the thrust map (:mod:`trimd.app.calibrate`; docs/method.md §7): a level hold, the operator
hangs a known weight at a known slot, a second level hold; the experiment is checked
and stored in the vehicle's trim history, and every later session of the vehicle uses it.
"""

from __future__ import annotations

import argparse
import asyncio
import re
import sys
from pathlib import Path

from trimd.app.calibrate import KnownWeight, calibrate_with_weight
from trimd.app.connect import open_link
from trimd.app.history.calibration import calibrated_profile
from trimd.app.jsonlines import print_result
from trimd.cli.argtypes import Subcommands
from trimd.cli.history_args import add_history_args, db_path, vehicle_of
from trimd.core.calibration import gains
from trimd.core.calibration_json import gain_to_dict
from trimd.core.errors import ProfileError, UsageError
from trimd.core.profile_yaml import load_profile

__all__ = ["register", "run"]

_MASS = re.compile(r"^(?P<kg>[-+]?\d+(\.\d*)?|[-+]?\.\d+)@(?P<slot>.+)$")


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "calibrate", help="calibrate the thrust map with a known weight",
        description="A level hold, then you hang a known weight at a ballast slot, then a "
        "second level hold: the thrusters' answer to the known weight calibrates their "
        "thrust map, stored in the vehicle's trim history and used by every later trim, "
        "verify hold and watch of the vehicle (docs/method.md §7).")
    p.add_argument("--link", required=True, help="sim[:opts] | mavlink:<conn> | "
                   "serial:<dev>[,<baud>]")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--mass", required=True, metavar="KG@SLOT",
                   help="the weight's net downward force in water [kgf] (negative: a "
                   "float's lift) and the ballast slot it hangs at, e.g. 0.5@W-front-stbd")
    p.add_argument("--uncertainty-pct", type=float, default=1.0,
                   help="1σ of the weight in water [%%] (default 1)")
    p.add_argument("--yes", action="store_true", help="command the vehicle without asking, "
                   "and take the weight as hung once the first hold ends (headless)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--no-history", action="store_true",
                   help="check the experiment against the profile alone; store nothing")
    add_history_args(p)
    p.set_defaults(func=run)


def _weight(text: str, uncertainty_pct: float) -> KnownWeight:
    m = _MASS.match(text.strip())
    if m is None:
        raise UsageError(f"--mass {text!r}: expected KG@SLOT, e.g. 0.5@W-front-stbd",
                         "trimd calibrate")
    return KnownWeight(float(m["kg"]), m["slot"].strip(), uncertainty_pct)


def _ask(text: str) -> bool:
    print(f"trimd calibrate: {text} [y/N] ", end="", file=sys.stderr, flush=True)
    return sys.stdin.readline().strip().lower() in ("y", "yes")


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    weight = _weight(args.mass, args.uncertainty_pct)
    profile.slot(weight.slot)  # a wrong slot fails before anything is commanded
    if not args.yes and not sys.stdin.isatty():
        raise ProfileError("headless without a terminal cannot ask for confirmation: "
                           "pass --yes to let trimd command the vehicle")
    if not args.yes and not _ask("two level holds: let trimd command the vehicle?"):
        return 1
    vehicle = vehicle_of(args, profile.name)
    db = None if args.no_history else Path(db_path(args))
    profile = calibrated_profile(db, vehicle, profile)

    def hung(text: str) -> bool:
        if args.yes:
            print(f"trimd calibrate: {text} (--yes: taken as done)", file=sys.stderr)
            return True
        return _ask(text)

    done = asyncio.run(calibrate_with_weight(lambda: open_link(args.link, profile), profile,
                                             weight, hung, db=db, vehicle=vehicle))
    determined = [g for g in gains(done.posterior, profile) if g.determined]
    lines = [done.outcome.message] + [
        f"  {g.thruster} {g.direction}: {g.mean_pct:+.1f} ± {g.std_pct:.1f} % "
        f"(prior ± {g.prior_std_pct:.1f} %)" for g in determined]
    print_result(args.json, {
        "type": "calibration", "vehicle": vehicle, "accepted": done.outcome.accepted,
        "message": done.outcome.message, "chi2": done.outcome.chi2,
        "sigma": done.outcome.sigma, "experiments": done.posterior.experiments,
        "gains": [gain_to_dict(g) for g in determined]}, "\n".join(lines))
    return 0 if done.outcome.accepted else 1
