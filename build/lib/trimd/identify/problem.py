"""The least-squares problem of one stage: experiments cut into segments, named parameters,
weighted simulation residuals and their finite-difference Jacobian in one batched run.

Parameter vector (all named; each free or fixed): the 18 hydrodynamic parameters of
:data:`trimd.identify.model.HYDRO_NAMES`, the thruster lag ``T_thr`` [s], the lead of the
thruster record over the motion record ``T_lead`` [s], and per
experiment a constant bias [rad/s] of each simulated body-rate output (a gyro bias).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from trimd.core.errors import DataError
from trimd.identify.data import Experiment
from trimd.identify.model import (
    HYDRO_NAMES,
    LAG,
    LEAD,
    STATE_NAMES,
    Stage,
    lagged_thrust,
    simulate,
)

__all__ = ["Problem", "bias_name"]

FloatArray = NDArray[np.float64]
_RATES = (3, 4, 5)


def bias_name(state: int, experiment: int) -> str:
    """Name of the bias of rate output ``state`` (3..5) in experiment ``experiment``."""
    return f"b_{STATE_NAMES[state]}[{experiment}]"


class Problem:
    """Simulation residuals of ``stage`` on ``experiments`` cut into segments of
    ``segment_steps`` steps, each started from the measured state.

    Parameters
    ----------
    experiments : same sample interval; at least one segment long.
    stage : which states are simulated and compared.
    mass_kg : rigid-body mass m [kg] (M_u = m + X_u̇ …).
    q_rest : restoring vector (:func:`trimd.identify.model.restoring_vector`).
    segment_steps : simulation horizon L [steps]; ``None``: each experiment whole (free
        run, one segment each; used for validation).
    weights : per compared output (order of ``stage.outputs``), multiplying its error.
    """

    def __init__(self, experiments: Sequence[Experiment], stage: Stage, mass_kg: float,
                 q_rest: FloatArray, segment_steps: int | None, weights: FloatArray) -> None:
        if not experiments:
            raise DataError("no experiment to fit")
        hs = [e.h_s for e in experiments]
        if max(hs) - min(hs) > 1e-3 * min(hs):
            raise DataError(f"experiments have different sample intervals: {sorted(set(hs))}")
        self.h = float(np.mean(hs))
        self.stage = stage
        self.mass = mass_kg
        self.q_rest = q_rest
        self.experiments = tuple(experiments)
        biases = [bias_name(s, j) for j in range(len(experiments)) for s in _RATES
                  if s in stage.states]
        self.names = (*HYDRO_NAMES, LAG, LEAD, *biases)
        self.index = {n: i for i, n in enumerate(self.names)}
        lengths = [len(e.t_s) for e in experiments]
        L = segment_steps or min(lengths) - 1
        if segment_steps is None and len(set(lengths)) > 1:
            raise DataError("free-run simulation needs experiments of equal length; "
                            "simulate them one at a time")
        starts, owner = [], []
        offset = 0
        for j, n in enumerate(lengths):
            k = (n - 1) // L
            starts += [offset + i * L for i in range(k)]
            owner += [j] * k
            offset += n
        if not starts:
            raise DataError(f"experiments shorter than one segment ({L * self.h:g} s)")
        self.L = L
        self.owner = np.array(owner)
        self.rows = np.array(starts)[None, :] + np.arange(L + 1)[:, None]   # (L+1, K)
        x = np.concatenate([e.x for e in experiments])
        self.exo = x[self.rows]                                              # (L+1, K, 8)
        self.y = self.exo[1:][..., list(stage.outputs)]                      # (L, K, n_out)
        self.weights = np.asarray(weights, float)
        self._tau_cache: dict[tuple[float, float], tuple[FloatArray, FloatArray]] = {}

    @property
    def n_residuals(self) -> int:
        return int(self.y.size)

    def _tau(self, lag: float, lead: float) -> tuple[FloatArray, FloatArray]:
        key = (lag, lead)
        if key not in self._tau_cache:
            parts = [lagged_thrust(e.tau, lag, self.h, lead) for e in self.experiments]
            start = np.concatenate([p[0] for p in parts])[self.rows]
            mid = np.concatenate([p[1] for p in parts])[self.rows]
            self._tau_cache = {key: (start, mid)}
        return self._tau_cache[key]

    def simulate(self, theta: FloatArray) -> FloatArray:
        """Predicted outputs for parameter vectors ``theta`` (B, P) sharing one lag and
        lead: shape (L, B, K, n_out)."""
        theta = np.atleast_2d(theta)
        lag, lead = float(theta[0, self.index[LAG]]), float(theta[0, self.index[LEAD]])
        mass = theta[:, 0:6].copy()
        mass[:, :3] += self.mass
        Dl, Dq = theta[:, 6:12], theta[:, 12:18]
        bias = np.zeros((theta.shape[0], len(self.experiments), 8))
        for name, i in self.index.items():
            if name.startswith("b_"):
                state = STATE_NAMES.index(name[2:name.index("[")])
                bias[:, int(name[name.index("[") + 1:-1]), state] = theta[:, i]
        b = bias[:, self.owner]                                              # (B, K, 8)
        x0 = self.exo[0][None] - b
        start, mid = self._tau(lag, lead)
        x = simulate(mass, Dl, Dq, self.q_rest, x0, self.exo, start, mid,
                     self.stage.states, self.h)
        y: FloatArray = (x + b[None])[..., list(self.stage.outputs)]
        return y

    def residuals(self, theta: FloatArray) -> FloatArray:
        """Weighted output errors (predicted − measured), flat, for one vector (P,)."""
        r: FloatArray = ((self.simulate(theta)[:, 0] - self.y) * self.weights).ravel()
        return r

    def jacobian(self, theta: FloatArray, free: Sequence[int], steps: FloatArray
                 ) -> FloatArray:
        """Forward-difference Jacobian of :meth:`residuals` in the ``free`` parameters with
        signed ``steps``: every parameter except the thrust timing (lag and lead: they
        change τ) in one batched simulation."""
        base = self.residuals(theta)
        J = np.empty((base.size, len(free)))
        timing = (self.index[LAG], self.index[LEAD])
        batch = [j for j, i in enumerate(free) if i not in timing]
        if batch:
            thetas = np.repeat(theta[None], len(batch), axis=0)
            for row, j in enumerate(batch):
                thetas[row, free[j]] += steps[j]
            y = self.simulate(thetas)
            for row, j in enumerate(batch):
                r = ((y[:, row] - self.y) * self.weights).ravel()
                J[:, j] = (r - base) / steps[j]
        for j, i in enumerate(free):
            if i in timing:
                t = theta.copy()
                t[i] += steps[j]
                J[:, j] = (self.residuals(t) - base) / steps[j]
        return J
