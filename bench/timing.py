"""Shared timing helper for benchmarks: best-of-N wall time of a callable."""

from __future__ import annotations

import time
from collections.abc import Callable

from bench.size import size


def best_time(fn: Callable[[], object], repeat: int = 5) -> float:
    """Smallest wall time [s] of ``repeat`` calls of ``fn`` (the least disturbed run; one
    call in a tiny run)."""
    best = float("inf")
    for _ in range(size(repeat, 1)):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best
