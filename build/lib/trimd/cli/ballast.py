"""``trimd ballast --profile P --estimate EST.json [--method M] [--json]``: propose ballast."""

from __future__ import annotations

import argparse
import json
from typing import Any

from trimd.app.files import read_estimate
from trimd.app.report import format_proposal
from trimd.ballast.lp import STAGE_NODES
from trimd.ballast.propose import METHODS, proposal_to_dict, propose_ballast
from trimd.cli.argtypes import integer
from trimd.core.profile_yaml import load_profile

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "ballast", help="propose ballast from an estimate (trimd solve --json)",
        description="Propose what to put in which ballast slot so the vehicle floats level "
        "and slightly positive with no thruster effort, and check it by physics "
        "(see docs/ballast.md).")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--estimate", required=True, help="EST.json: the output of trimd solve "
                   "--json, trimd run's report JSON, or trimd run --json lines")
    p.add_argument("--method", choices=METHODS, default="milp",
                   help="lp, line, general or milp (default: milp, the real pieces)")
    p.add_argument("--node-limit", type=integer(1), default=STAGE_NODES, metavar="N",
                   help="branch-and-bound nodes per solver stage (milp); when reached, the "
                   "best proposal found is printed and says so; a node budget, not a time "
                   f"limit, so the proposal is the same on any machine (default {STAGE_NODES})")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    proposal = propose_ballast(read_estimate(args.estimate), profile, args.method,
                               node_limit=args.node_limit)
    print(json.dumps(proposal_to_dict(proposal), allow_nan=False) if args.json
          else format_proposal(proposal))
    return 0
