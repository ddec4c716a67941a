"""How big a benchmark runs: its full size by default, a tiny one with
``TRIMD_BENCH_TINY=1`` (``tests/test_bench_smoke.py`` runs every module so, so that
``make bench`` cannot rot; the figures of a tiny run mean nothing). A module's own
environment variables (``TRIMD_BENCH_MC_N`` …) still win over both."""

from __future__ import annotations

import dataclasses
import os
from typing import TypeVar

from trimd.core.profile import Profile

T = TypeVar("T")

TINY = os.environ.get("TRIMD_BENCH_TINY", "") not in ("", "0")
#: At the tiny size a hold collects for at most this long [s] of simulated time (the
#: shipped profiles' ``collect_max_s``: 120 s and 180 s), for the sessions that would
#: otherwise collect to the end (:func:`sized_profile`).
TINY_COLLECT_MAX_S = 15.0


def size(full: T, tiny: T) -> T:
    """``tiny`` when ``TRIMD_BENCH_TINY`` is set, else ``full``."""
    return tiny if TINY else full


def sized_profile(profile: Profile) -> Profile:
    """``profile`` itself at the full size; at the tiny size the same with its holds'
    ``collect_max_s`` [s] cut to :data:`TINY_COLLECT_MAX_S` (every step of a session still
    runs, each hold on fewer samples)."""
    if not TINY:
        return profile
    limits = dataclasses.replace(profile.procedure,
                                 collect_max_s=min(profile.procedure.collect_max_s,
                                                   TINY_COLLECT_MAX_S))
    return dataclasses.replace(profile, procedure=limits)
