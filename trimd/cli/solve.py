"""``trimd solve HOLDS.csv --profile P [--json]``: the static estimate from recorded holds;
``--json``: one ``estimate`` line (the estimate's JSON shape, with ``ballast``: the
proposal, when asked for)."""

from __future__ import annotations

import argparse

from trimd.app.holdfile import read_hold_csv
from trimd.app.jsonlines import print_result
from trimd.app.report import format_estimate, format_proposal
from trimd.ballast.propose import METHODS, proposal_to_dict, propose_ballast
from trimd.cli.argtypes import Subcommands
from trimd.core.estimate import estimate_static
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.profile_yaml import load_profile

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "solve", help="estimate the centre of gravity and extra mass from a hold CSV",
        description="Estimate weight, extra mass and centre of gravity from steady holds "
        "(see trimd/app/holdfile.py for the CSV columns).")
    p.add_argument("holds", help="CSV of samples: time_s, roll_deg, pitch_deg and τ or pwm_N")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--ballast", nargs="?", const="milp", choices=METHODS, metavar="METHOD",
                   help=f"also propose ballast ({', '.join(METHODS)}; default milp)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    est = estimate_static(read_hold_csv(args.holds, profile), profile)
    proposal = propose_ballast(est, profile, method=args.ballast) if args.ballast else None
    out = {"type": "estimate", **estimate_to_dict(est)}
    text = format_estimate(est)
    if proposal is not None:
        out["ballast"] = proposal_to_dict(proposal)
        text += "\n\n" + format_proposal(proposal)
    print_result(args.json, out, text)
    return 0
