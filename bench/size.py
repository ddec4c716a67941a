"""How big a benchmark runs: its full size by default, a tiny one with
``TRIMD_BENCH_TINY=1`` (``tests/test_bench_smoke.py`` runs every module so, so that
``make bench`` cannot rot; the figures of a tiny run mean nothing). A module's own
environment variables (``TRIMD_BENCH_MC_N`` …) still win over both."""

from __future__ import annotations

import os
from typing import TypeVar

T = TypeVar("T")

TINY = os.environ.get("TRIMD_BENCH_TINY", "") not in ("", "0")


def size(full: T, tiny: T) -> T:
    """``tiny`` when ``TRIMD_BENCH_TINY`` is set, else ``full``."""
    return tiny if TINY else full
