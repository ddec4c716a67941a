"""``trimd history [--vehicle V] [--json] [--db PATH] [--plot FILE]``: what the trim
history holds for a vehicle (docs/operator.md, "The trim history")."""

from __future__ import annotations

import argparse
from pathlib import Path

from trimd.app.history import History
from trimd.app.history.report import format_history, history_to_dict
from trimd.app.jsonlines import print_result
from trimd.cli.argtypes import Subcommands
from trimd.cli.history_args import add_db_arg, db_path
from trimd.core.errors import DataError

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "history", help="list a vehicle's trims, installed ballast and watch alerts",
        description="List what the trim history holds: every trim's estimate and proposal, "
        "the ballast installed, watch alerts and verify holds (all vehicles unless "
        "--vehicle); --plot draws W − B and the centre of gravity over time.")
    p.add_argument("--vehicle", metavar="NAME", help="only this vehicle")
    add_db_arg(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="FILE", help="write a PNG of W − B and the centre of "
                   "gravity over time (needs one vehicle: --vehicle, or a history of one)")
    p.set_defaults(func=run)


def _nothing(args: argparse.Namespace, path: Path, message: str) -> int:
    """Say that there is nothing to list (``--json``: a history with no vehicles)."""
    print_result(args.json, {"type": "history", "db": str(path), "vehicles": [],
                             "message": message}, message)
    return 0


def run(args: argparse.Namespace) -> int:
    path = Path(db_path(args))
    if not path.exists():
        return _nothing(args, path, f"no trim history yet: {path} does not exist (trimd run "
                        "and trimd ballast apply write it)")
    with History(path) as history:
        known = history.vehicles()
        if args.vehicle and args.vehicle not in known:
            return _nothing(args, path, f"no records for vehicle {args.vehicle} in {path} "
                            f"(vehicles: {', '.join(known) or 'none'})")
        vehicles = [args.vehicle] if args.vehicle else known
        if not vehicles:
            return _nothing(args, path, f"the trim history {path} is empty: no trim, "
                            "installed ballast or watch record yet")
        if args.plot:
            from trimd.app.history.plot import write_history_plot  # matplotlib: 0.7 s

            if len(vehicles) > 1:
                raise DataError(f"--plot draws one vehicle; pick one with --vehicle "
                                f"({', '.join(vehicles)})")
            n = write_history_plot(history, vehicles[0], Path(args.plot))
            print_result(args.json, {"type": "plot", "file": args.plot,
                                     "vehicle": vehicles[0], "trims": n},
                         f"wrote {args.plot}: {n} trim(s) of {vehicles[0]}")
            return 0
        print_result(args.json, {"type": "history", **history_to_dict(history, vehicles)},
                     format_history(history, vehicles))
    return 0
