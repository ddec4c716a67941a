"""``trimd ballast --profile P --estimate EST.json [--method M] [--json]``: propose ballast."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from trimd.ballast import (
    METHODS,
    TIME_LIMIT_S,
    format_proposal,
    proposal_to_dict,
    propose_ballast,
)
from trimd.errors import DataError
from trimd.estimate import StaticEstimate
from trimd.estimate_io import estimate_from_dict
from trimd.profile import load_profile

__all__ = ["read_estimate", "register", "run"]


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
    p.add_argument("--time-limit", type=float, default=TIME_LIMIT_S, metavar="S",
                   help=f"solver time limit [s]; when reached, the best proposal found is "
                   f"printed and says so (default {TIME_LIMIT_S:g})")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def _estimate_json(text: str, path: str | Path) -> object:
    """The estimate's JSON object in ``text``: the file itself (``trimd solve --json``),
    its ``estimate`` member (``trimd run``'s report), or that of the last ``result`` line
    of ``trimd run --json``."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        lines = []
        for line in filter(str.strip, text.splitlines()):
            try:
                lines.append(json.loads(line))
            except json.JSONDecodeError:
                raise DataError(f"{path}: not valid JSON ({exc})") from None
        results = [x for x in lines if isinstance(x, dict) and x.get("type") == "result"]
        if not results:
            raise DataError(f"{path}: no result line (trimd run --json)") from None
        data = results[-1]
    if isinstance(data, dict) and "weight_N" not in data and "estimate" in data:
        if data["estimate"] is None:
            raise DataError(f"{path}: that session produced no estimate")
        return data["estimate"]
    return data


def read_estimate(path: str | Path) -> StaticEstimate:
    """The estimate in ``path`` (any form :func:`_estimate_json` takes); DataError naming
    the file for anything unusable."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise DataError(f"{path}: cannot read estimate ({exc.strerror})") from None
    try:
        return estimate_from_dict(_estimate_json(text, path), str(path))
    except DataError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise DataError(f"{path}: malformed estimate ({type(exc).__name__}: {exc}); expected "
                        "the output of trimd solve --json") from None


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    if not args.time_limit > 0:
        raise DataError(f"--time-limit must be a positive number of seconds, got {args.time_limit}")
    proposal = propose_ballast(read_estimate(args.estimate), profile, args.method,
                               time_limit_s=args.time_limit)
    print(json.dumps(proposal_to_dict(proposal), allow_nan=False) if args.json
          else format_proposal(proposal))
    return 0
