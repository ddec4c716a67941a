"""The lexicographic solve of a ballast programme (:mod:`trimd.ballast.lp`): first with
the slacks held at zero, else stage by stage (the net-buoyancy window, the level, the
ballast), each optimum held for the next; every integer solve within a budget of
branch-and-bound nodes, never a time limit, so that a replay proposes exactly what the
live run did on any machine (docs/ballast.md, "Search limits").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trimd.ballast.highs import cut_short, solve
from trimd.ballast.lp import N_SLACK, Programme
from trimd.core.types import FloatArray

__all__ = ["HOLD_RETRY", "STAGE_NODES", "STRICT_NODES", "Solution", "solve_programme"]

#: Branch-and-bound nodes of the solve exactly as asked (slacks at zero) and by default of
#: each later stage: budgets, not time limits (the same proposal on any machine).
STRICT_NODES = 200
STAGE_NODES = 20_000
#: How far beyond its optimum [relative, and absolute in its units] a stage's optimum is
#: held when the solver calls the next stage infeasible (:func:`_solve_stages`).
HOLD_RETRY = 1e-5


@dataclass(frozen=True)
class Solution:
    """Item amounts (rounded to whole pieces where integer) or the solver's complaint.

    ``note`` says when a time limit cut a solve short (then the amounts are the best
    found, not proven optimal); empty otherwise.
    """

    success: bool
    message: str
    amounts: FloatArray
    note: str = ""


def _solve_stages(prog: Programme, upper: FloatArray,
                  objectives: Sequence[tuple[str, FloatArray]], integer: NDArray[np.int_] | None,
                  node_limit: int) -> Solution:
    """Solve ``objectives`` in order, holding each optimum (to 1e-7 + 1e-6 relative),
    each within ``node_limit`` branch-and-bound nodes. A stage cut short keeps its best
    solution, or when it found none, the previous stage's (which meets every row held so
    far). A stage the solver calls infeasible after an earlier one was solved is
    solved again with the optima held to :data:`HOLD_RETRY` (the earlier solution meets
    every row: what failed was the solver's tolerance on the held optima), and keeps the
    previous stage's solution when that fails too; the note says so."""
    A, b = prog.A, prog.b
    x: FloatArray | None = None
    cut: list[str] = []
    kept: list[str] = []
    looser = np.zeros(len(b))
    for name, c in objectives:
        res = solve(c, A, b, upper, integer, node_limit)
        if res.x is None and x is not None and not cut_short(res):
            res = solve(c, A, b + looser, upper, integer, node_limit)
        if cut_short(res):
            cut.append(name)
        if res.x is not None:
            x, fun = res.x, float(res.fun)
        elif x is None:
            why = "search limit reached before any solution" if cut_short(res) else res.message
            return Solution(False, f"no solution at the '{name}' stage: {why}",
                            np.zeros(len(prog.items)), "search limit" if cut else "")
        else:
            if not cut_short(res):
                kept.append(name)
            fun = float(c @ x)
        A = np.vstack([A, c])
        b = np.r_[b, fun + 1e-7 + 1e-6 * abs(fun)]
        looser = np.r_[looser, HOLD_RETRY * (1.0 + abs(fun))]
    assert x is not None  # objectives is never empty
    u = np.clip(x[:len(prog.items)], 0.0, None)
    notes = ([f"search limit reached at the {', '.join(repr(n) for n in cut)} stage: best "
              "found, not proven optimal"] if cut else []) + (
        [f"the {', '.join(repr(n) for n in kept)} stage found no solution within the "
         "solver's tolerances: the previous stage's kept, not optimal for it"] if kept else [])
    return Solution(True, "ok", u if integer is None else np.round(u), "; ".join(notes))


def solve_programme(prog: Programme, *, relax: bool = False,
                    node_limit: int = STAGE_NODES) -> Solution:
    """Item amounts that meet the requirement at least ballast, or the best achievable.

    First with the slacks held at zero (one solve when the requirement can be met, within
    :data:`STRICT_NODES` nodes at most; unless ``prog.exact`` is False), else
    lexicographically: window slack, level slack, ballast, each within ``node_limit``
    branch-and-bound nodes. ``relax`` drops integrality (the LP relaxation, solved by
    linprog). Deterministic: no time limit, so the answer does not depend on the machine.
    """
    integer = None if relax or not np.any(prog.integrality) else prog.integrality
    n = len(prog.items)
    note = ""
    strict_nodes = min(STRICT_NODES, node_limit)
    if prog.exact:
        strict = np.r_[prog.upper[:n], np.zeros(N_SLACK), prog.upper[n + N_SLACK:]]
        exact = _solve_stages(prog, strict, prog.objectives[-1:], integer, strict_nodes)
        if exact.success:
            return exact
        if exact.note:
            note = (f"no level proposal found within the exact search's limit ({strict_nodes}"
                    " nodes)")
    lex = _solve_stages(prog, prog.upper, prog.objectives, integer, node_limit)
    return Solution(lex.success, lex.message, lex.amounts,
                    "; ".join(n for n in (note, lex.note) if n))
