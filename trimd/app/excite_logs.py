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

__all__ = ["experiments_by_stage", "read_log", "recorded_stage"]


def read_log(path: str, profile: Profile) -> list[Experiment]:
    """The experiments of a recorded ``.tlog`` or DataFlash ``.BIN`` (trimd.logs.log)."""
    samples = list(open_log(path, profile).samples())
    return experiments_from_samples(samples, profile, label=Path(path).name)


def recorded_stage(path: str) -> str | None:
    """The stage a ``trimd excite`` recording names (:func:`stage_of_notice` on trimd's
    own notices); None for a DataFlash log or a log without it."""
    return _notes(path)[0]


def _notes(path: str) -> tuple[str | None, str | None]:
    """What trimd's own notices in the log at ``path`` say, read once: the stage it names
    (:func:`recorded_stage`) and the notice that its excitation stopped early (at the edge
    of its envelope, :mod:`trimd.identify.envelope`), each None when absent."""
    stage = early = None
    for text in recorded_notices(path):
        stage = stage or stage_of_notice(text)
        if early is None and text.startswith(STOP_EARLY):
            early = text
    return stage, early


def experiments_by_stage(paths: Sequence[str], profile: Profile, stage: str | None
                         ) -> tuple[dict[str, list[Experiment]], dict[str, str]]:
    """The experiments of ``paths`` grouped by stage (``stage`` for all, else each
    recording's own), and per path whose excitation stopped early, the notice that says
    so."""
    out: dict[str, list[Experiment]] = {}
    early: dict[str, str] = {}
    for path in paths:
        named, stopped = _notes(path)
        own = stage or named
        if own is None:
            raise DataError(f"{path}: the log does not say which stage it holds (not a trimd "
                            f"excite recording): pass --stage ({', '.join(STAGES)})")
        out.setdefault(own, []).extend(read_log(path, profile))
        if stopped is not None:
            early[path] = stopped
    return out, early
