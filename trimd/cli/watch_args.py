"""The options of the passive watch itself (its baseline and its change test), shared by
``trimd watch`` and ``trimd serve``, and the :class:`~trimd.core.watch.TrimWatch` they
make."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

from trimd.app.history import History
from trimd.app.history.baseline import latest_baseline
from trimd.cli.argtypes import bounded
from trimd.cli.history_args import db_path, vehicle_of
from trimd.core.change import Baseline, baseline_from_estimate
from trimd.core.errors import DataError
from trimd.core.estimate_json import estimate_from_dict
from trimd.core.profile import Profile
from trimd.core.watch import FALSE_ALARMS_PER_H, MAX_SEGMENT_S, TrimWatch

__all__ = ["add_watch_args", "new_watch"]


def add_watch_args(p: argparse.ArgumentParser) -> None:
    """The options of the watch itself, shared with ``trimd serve``: its baseline and its
    change test."""
    p.add_argument("--baseline", metavar="EST.json", help="compare with this estimate "
                   "(trimd solve --json), or 'last': the vehicle's latest measurement in the "
                   "history (its last trim, or a verify hold of its ballast if newer), "
                   "instead of the first segments")
    p.add_argument("--baseline-segments", type=int, default=3, metavar="N",
                   help="level segments that form the baseline (default 3)")
    p.add_argument("--max-segment", type=bounded(10.0), default=MAX_SEGMENT_S, metavar="S",
                   help=f"longest segment [s] (default {MAX_SEGMENT_S:g})")
    p.add_argument("--false-alarms-per-h", type=bounded(0.0), default=FALSE_ALARMS_PER_H,
                   metavar="R", help="target false-alarm rate of the change test "
                   f"(default {FALSE_ALARMS_PER_H:g} per hour)")


def _baseline(args: argparse.Namespace, profile: Profile) -> Baseline | None:
    path = args.baseline
    if path is None:
        return None
    if path == "last":
        with History(db_path(args)) as history:
            latest = latest_baseline(history, vehicle_of(args, profile.name))
        print(f"trimd watch: baseline: {latest.baseline.source}", file=sys.stderr)
        if latest.warning:
            print(f"trimd: warning: {latest.warning}", file=sys.stderr)
        return latest.baseline
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise DataError(f"--baseline {path}: {exc}") from None
    return baseline_from_estimate(estimate_from_dict(data, path), f"the estimate in {path}")


def new_watch(args: argparse.Namespace, profile: Profile,
              clock: Callable[[float], str] | None = None) -> TrimWatch:
    """A watch with the options of :func:`add_watch_args`; ``clock`` names a sample time
    [s] for people (None: ``t = … s``)."""
    kwargs = {"clock": clock} if clock is not None else {}
    return TrimWatch(profile, baseline=_baseline(args, profile),
                     baseline_segments=args.baseline_segments, max_segment_s=args.max_segment,
                     false_alarms_per_h=args.false_alarms_per_h, **kwargs)
