"""``trimd ballast --profile P --estimate EST.json [--method M] [--json]``: propose ballast
(from the ballast installed: the history's record for the vehicle, else the profile's);
``trimd ballast apply``: record what was installed (:mod:`trimd.cli.ballast_apply`)."""

from __future__ import annotations

import argparse

from trimd.app.files import read_estimate
from trimd.app.history.installed import current_installed
from trimd.app.jsonlines import print_result
from trimd.app.report import format_proposal
from trimd.ballast.propose import METHODS, proposal_to_dict, propose_ballast
from trimd.ballast.stages import STAGE_NODES
from trimd.cli import ballast_apply
from trimd.cli.argtypes import Subcommands, integer
from trimd.cli.history_args import add_history_args, db_path, vehicle_of
from trimd.core.profile_yaml import load_profile

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "ballast", help="propose ballast from an estimate (trimd solve --json); "
        "'ballast apply' records what was installed",
        description="Propose what to put in which ballast slot, or take out or move, so the "
        "vehicle floats level and slightly positive with no thruster effort, and check it "
        "by physics (see docs/ballast.md). The proposal starts from the ballast installed: "
        "the trim history's record for the vehicle, else the profile's ballast.installed. "
        "'trimd ballast apply --help': record what was actually installed.")
    p.add_argument("--profile", help="vehicle profile (YAML path or name); required")
    p.add_argument("--estimate", help="EST.json: the output of trimd solve --json, trimd "
                   "run's report JSON, or trimd run --json lines; required")
    p.add_argument("--method", choices=METHODS, default="milp",
                   help="lp, line, general or milp (default: milp, the real pieces)")
    p.add_argument("--node-limit", type=integer(1), default=STAGE_NODES, metavar="N",
                   help="branch-and-bound nodes per solver stage (milp); when reached, the "
                   "best proposal found is printed and says so; a node budget, not a time "
                   f"limit, so the proposal is the same on any machine (default {STAGE_NODES})")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    add_history_args(p)
    actions = p.add_subparsers(dest="ballast_action", metavar="ACTION")
    ballast_apply.register(actions)
    p.set_defaults(func=run, parser=p)


def run(args: argparse.Namespace) -> int:
    missing = [f"--{k}" for k in ("profile", "estimate") if not getattr(args, k)]
    if missing:
        args.parser.error(f"the following arguments are required: {', '.join(missing)}")
    profile = load_profile(args.profile)
    installed, _ = current_installed(db_path(args), vehicle_of(args, profile.name), profile)
    proposal = propose_ballast(read_estimate(args.estimate), profile, args.method,
                               node_limit=args.node_limit, installed=installed)
    print_result(args.json, {"type": "proposal", **proposal_to_dict(proposal)},
                 format_proposal(proposal))
    return 0
