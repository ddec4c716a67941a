"""The programmes' solver: HiGHS through scipy.optimize (``linprog`` for the continuous
programmes, ``milp`` for the integer ones), with its native output kept off trimd's
standard output.

HiGHS now and then prints a debug line from C straight to file descriptor 1 whatever its
display options ("HighsMipSolverData:: transformNewIntegerFeasibleSolution
tmpSolver.run();", HiGHS issue 2783): on a hard search it would land between the JSON
lines of ``trimd run --json`` or the headless progress. :func:`solver_stdout_to_log`
points descriptor 1 at a temporary file for the length of a solve and logs what came, at
debug level. A solve runs in the session's own thread, which is the only one that writes
to standard output (the terminal UI draws on standard error).
"""

from __future__ import annotations

import logging
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trimd.core.types import FloatArray

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult

__all__ = ["cut_short", "solve", "solver_stdout_to_log"]

log = logging.getLogger(__name__)

#: Relative optimality gap of every integer solve.
_MIP_GAP = 1e-6


def solve(c: FloatArray, A: FloatArray, b: FloatArray, upper: FloatArray,
          integrality: NDArray[np.int_] | None, node_limit: int) -> OptimizeResult:
    """min c·x subject to A·x ≤ b, 0 ≤ x ≤ ``upper``; the columns where ``integrality`` is
    1 integer (None: all continuous), within ``node_limit`` branch-and-bound nodes."""
    from scipy.optimize import Bounds, LinearConstraint, linprog, milp  # 0.5 s: when solving

    with solver_stdout_to_log():
        if integrality is None:
            return linprog(c, A_ub=A, b_ub=b, method="highs",
                           bounds=np.column_stack([np.zeros_like(upper), upper]))
        return milp(c, constraints=LinearConstraint(A, -np.inf, b), integrality=integrality,
                    bounds=Bounds(0.0, upper),
                    options={"mip_rel_gap": _MIP_GAP, "node_limit": node_limit})


def cut_short(res: OptimizeResult) -> bool:
    """Did the solver stop at a limit (status 1) or its node budget? (scipy reports
    HiGHS's node limit as status 4 with the model status in the message.)"""
    return bool(res.status == 1 or (res.status == 4 and "limit reached" in res.message))


@contextmanager
def solver_stdout_to_log() -> Iterator[None]:
    """While it lasts, what native code writes to descriptor 1 goes to the debug log."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 1)
            try:
                yield
            finally:
                os.dup2(saved, 1)
                sink.seek(0)
                printed = sink.read().decode("utf-8", "replace").strip()
                if printed:
                    log.debug("the MILP solver printed: %s", printed)
    finally:
        os.close(saved)
