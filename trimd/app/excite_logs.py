"""The recordings of ``trimd excite`` as ``trimd identify`` reads them: their experiments,
the stage each names, and whether its excitation stopped early."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from trimd.core.errors import DataError
from trimd.core.profile import Profile
from trimd.identify.data import Experiment, experiments_from_samples
from trimd.identify.envelope import STOP_EARLY
from trimd.identify.experiment import stage_of_notice
from trimd.identify.model import STAGES
from trimd.logs.log import open_log
from trimd.logs.replay import recorded_notices

__all__ = ["experiments_by_stage", "read_log", "recorded_stage", "stopped_early"]


def read_log(path: str, profile: Profile) -> list[Experiment]:
    """The experiments of a recorded ``.tlog`` or DataFlash ``.BIN`` (trimd.logs.log)."""
    samples = list(open_log(path, profile).samples())
    return experiments_from_samples(samples, profile, label=Path(path).name)


def recorded_stage(path: str) -> str | None:
    """The stage a ``trimd excite`` recording names (:func:`stage_of_notice` on trimd's
    own notices); None for a DataFlash log or a log without it."""
    return next((st for st in map(stage_of_notice, recorded_notices(path)) if st is not None),
                None)


def stopped_early(path: str) -> str | None:
    """The notice of a ``trimd excite`` recording whose excitation stopped early (at the
    edge of its envelope, :mod:`trimd.identify.envelope`); None when it did not."""
    return next((t for t in recorded_notices(path) if t.startswith(STOP_EARLY)), None)


def experiments_by_stage(paths: Sequence[str], profile: Profile, stage: str | None
              ) -> dict[str, list[Experiment]]:
    """The experiments of ``paths`` grouped by stage (``stage`` for all, else each
    recording's own)."""
    out: dict[str, list[Experiment]] = {}
    for path in paths:
        own = stage or recorded_stage(path)
        if own is None:
            raise DataError(f"{path}: the log does not say which stage it holds (not a trimd "
                            f"excite recording): pass --stage ({', '.join(STAGES)})")
        out.setdefault(own, []).extend(read_log(path, profile))
    return out
