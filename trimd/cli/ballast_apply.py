"""``trimd ballast apply --profile P [--estimate EST.json] [--set SLOT:PIECE=COUNT …]``:
record in the trim history the ballast now installed on the vehicle.

By default that is the ``milp`` proposal for the estimate, carried out on what was
installed before (the history's record for the vehicle, else the profile's
``ballast.installed``); ``--set`` edits counts of it (``COUNT`` 0 takes a kind out of a
slot), and without ``--estimate`` edits what was installed before. The whole
configuration is recorded, in one transaction, with its source: ``proposal`` or
``edited``. With an estimate, the physics check of the recorded configuration is printed:
the passive roll, pitch and net buoyancy it gives.
"""

from __future__ import annotations

import argparse
import dataclasses
import re

from trimd.app.apply import apply_ballast
from trimd.app.files import read_estimate
from trimd.app.jsonlines import print_result
from trimd.app.report import format_applied
from trimd.cli.argtypes import Subcommands
from trimd.cli.history_args import add_history_args, db_path, vehicle_of
from trimd.core.errors import ProfileError
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.profile_yaml import load_profile

__all__ = ["parse_set", "register", "run"]

_SET = re.compile(r"^(?P<slot>[^:=]+):(?P<piece>[^:=]+)=(?P<count>\d+)$")


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "apply", help="record the ballast installed on the vehicle",
        description="Record in the trim history what was actually installed: the milp "
        "proposal for --estimate (from what was installed before), or that with counts "
        "edited by --set. Later proposals for the vehicle start from it.")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--estimate", help="EST.json: the estimate the proposal is for (trimd "
                   "solve --json, trimd run's report JSON or --json lines)")
    p.add_argument("--set", action="append", default=[], metavar="SLOT:PIECE=COUNT",
                   help="the count of a piece kind in a slot, as installed (0: none); "
                   "repeat for each slot and kind you changed from the proposal")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    add_history_args(p)
    p.set_defaults(func=run)


def parse_set(texts: list[str], profile: Profile) -> list[InstalledPiece]:
    """``SLOT:PIECE=COUNT`` items, names checked against the profile and spelled as it
    spells them (ProfileError naming the item otherwise)."""
    items = []
    for text in texts:
        m = _SET.match(text.strip())
        if m is None:
            raise ProfileError(f"--set {text!r}: expected SLOT:PIECE=COUNT, e.g. "
                               f"W-aft-ctr:lead-200g=2")
        items.append(InstalledPiece(m["slot"].strip(), m["piece"].strip(), int(m["count"])))
    profile.resolve_installed([dataclasses.replace(x, count=0) for x in items], "--set")
    return [InstalledPiece(profile.slot(x.slot).name, profile.piece(x.piece).name, x.count)
            for x in items]


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    estimate = read_estimate(args.estimate) if args.estimate else None
    if estimate is None and not args.set:
        raise ProfileError("trimd ballast apply: give --estimate (record its proposal) or "
                           "--set SLOT:PIECE=COUNT (record edited counts), or both")
    applied = apply_ballast(db_path(args), vehicle_of(args, profile.name), profile,
                            estimate=estimate, edits=parse_set(args.set, profile))
    trim = applied.trim
    print_result(args.json, {
        "type": "installed", "vehicle": applied.vehicle, "db": str(applied.db),
        "source": applied.source, "before_from": applied.before_from,
        "installed": [{"slot": x.slot, "piece": x.piece, "count": x.count}
                      for x in applied.installed],
        "changes": list(applied.changes),
        "predicted": None if trim is None or not trim.stable else {
            "roll_deg": trim.roll_deg, "pitch_deg": trim.pitch_deg,
            "trim_std_deg": [trim.roll_std_deg, trim.pitch_std_deg],
            "net_buoyancy_N": trim.net_buoyancy_N,
            "net_buoyancy_pct": trim.net_buoyancy_pct}}, format_applied(applied))
    return 0
