"""The least-squares problem of one stage: experiments cut into segments, named parameters,
weighted simulation residuals and their finite-difference Jacobian in one batched run.

Each output is compared only at the samples of its own stream (``Experiment.fresh``: a
DVL at 5 Hz beside attitude at 20 Hz is compared every fourth step, never at its
interpolated values between), and each segment starts at a sample of every simulated
stream that is measured (never from an interpolated state).

Parameter vector (all named; each free or fixed): the 18 hydrodynamic parameters of
:data:`trimd.identify.model.HYDRO_NAMES`, the thruster lag ``T_thr`` [s], the lead of the
thruster record over the motion record ``T_lead`` [s], and per
experiment a constant bias [rad/s] of each simulated body-rate output (a gyro bias).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trimd.core.errors import DataError
from trimd.core.types import FloatArray
from trimd.identify.data import Experiment, z_dot
from trimd.identify.depthrate import DepthRate
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

_RATES = (3, 4, 5)


def _measured_starts(experiment: Experiment, states: Sequence[int], length: int
                     ) -> list[int]:
    """Start indices of the segments of ``length`` samples cut from ``experiment``, each at
    a sample where every simulated state that is measured at all is a sample of its own
    stream (``Experiment.measured``), the next one at or after the previous segment's
    end.

    A segment starts from the measured state; between the samples of a slower stream (a
    DVL at 5 Hz beside attitude at 20 Hz) that state is an interpolation, and its error
    at the start of every segment biased the fitted thruster timing, which the inertia of
    a fast DOF trades against (docs/identification.md, "Fast DOFs at slow streams")."""
    fresh = experiment.measured[:, list(states)]
    seen = fresh[:, fresh.any(axis=0)]
    ok = np.flatnonzero(seen.all(axis=1)) if seen.shape[1] else np.arange(len(fresh))
    out: list[int] = []
    i = 0
    n = len(experiment.t_s)
    while True:
        k = int(np.searchsorted(ok, i))
        if k == len(ok) or ok[k] + length > n - 1:
            return out
        out.append(int(ok[k]))
        i = int(ok[k]) + length


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
    stride : samples per integration step (the simulation runs at the sample interval
        times ``stride`` and is compared at every ``stride``-th sample; the thrust at the
        half steps stays exact, the exogenous states are interpolated linearly).
    """

    def __init__(self, experiments: Sequence[Experiment], stage: Stage, mass_kg: float,
                 q_rest: FloatArray, segment_steps: int | None, weights: FloatArray,
                 stride: int = 1) -> None:
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
        if segment_steps is None and len(set(lengths)) > 1:
            raise DataError("free-run simulation needs experiments of equal length; "
                            "simulate them one at a time")
        self.stride = d = max(1, int(stride))
        L = d * max(1, (segment_steps or min(lengths) - 1) // d)   # samples per segment
        starts, owner = [], []
        offset = 0
        for j, e in enumerate(experiments):
            own = ([0] if segment_steps is None
                   else _measured_starts(e, stage.states, L))
            starts += [offset + i for i in own]
            owner += [j] * len(own)
            offset += len(e.t_s)
        if not starts:
            raise DataError(f"experiments shorter than one segment ({L * self.h:g} s)")
        self.step = d * self.h
        self.owner = np.array(owner)
        self.rows = np.array(starts)[None, :] + d * np.arange(L // d + 1)[:, None]
        self._n = offset
        x = np.concatenate([e.x for e in experiments])
        self.exo = x[self.rows]                                              # (L+1, K, 8)
        self.y = self.exo[1:][..., list(stage.outputs)]                      # (L, K, n_out)
        fresh = np.concatenate([e.measured for e in experiments])
        compared = fresh[self.rows][1:][..., list(stage.outputs)]
        #: without a DVL, heave is compared as the depth rate the depth sensor shows
        self.depth_rate = (DepthRate(experiments, self.rows, self.step)
                           if segment_steps is not None and 2 in stage.outputs
                           and not all(e.dvl for e in experiments) else None)
        if self.depth_rate is not None:
            j = stage.outputs.index(2)
            self.y = self.y.copy()
            self.y[..., j] = self.depth_rate.measured
            compared[..., j] = self.depth_rate.compared
        #: which residuals are compared: outputs at samples of their own stream, flat
        self.compared = compared.ravel()
        self.weights = np.asarray(weights, float)
        #: largest thruster lead [s] (Experiment.lead_max_s)
        self.lead_max = max(e.lead_max_s for e in experiments)
        self._tau_cache: dict[tuple[float, float], tuple[FloatArray, FloatArray]] = {}

    @property
    def n_residuals(self) -> int:
        return int(self.compared.sum())

    def _tau(self, lag: float, lead: float) -> tuple[FloatArray, FloatArray]:
        """Lagged thrust at the steps and half steps of every segment, (L + 1, K, 6) each;
        the last few (lag, lead) pairs are kept (a Jacobian's base and timing columns)."""
        key = (lag, lead)
        if key not in self._tau_cache:
            parts = [lagged_thrust(e.tau, lag, self.h, lead) for e in self.experiments]
            every = np.concatenate([p[0] for p in parts])
            halves = np.concatenate([p[1] for p in parts])
            d = self.stride
            start = every[self.rows]
            # the half step of a stride d: a sample (d even) or a sample's half step (d odd)
            mid_rows = np.minimum(self.rows + d // 2, self._n - 1)
            mid = every[mid_rows] if d % 2 == 0 else halves[mid_rows]
            if len(self._tau_cache) >= 4:
                self._tau_cache.pop(next(iter(self._tau_cache)))
            self._tau_cache[key] = (start, mid)
        return self._tau_cache[key]

    def _taus(self, theta: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Thrust of each row of ``theta`` (B, P): shared (L + 1, K, 6) when every row has
        the same lag and lead, else per row (L + 1, B, K, 6)."""
        timing = theta[:, [self.index[LAG], self.index[LEAD]]]
        keys = [(float(a), float(b)) for a, b in timing]
        if len(set(keys)) == 1:
            return self._tau(*keys[0])
        pairs = [self._tau(*k) for k in keys]
        return (np.stack([p[0] for p in pairs], axis=1),
                np.stack([p[1] for p in pairs], axis=1))

    def simulate(self, theta: FloatArray) -> FloatArray:
        """Predicted outputs for parameter vectors ``theta`` (B, P): shape
        (L, B, K, n_out)."""
        theta = np.atleast_2d(theta)
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
        start, mid = self._taus(theta)
        x = simulate(mass, Dl, Dq, self.q_rest, x0, self.exo, start, mid,
                     self.stage.states, self.step)
        y: FloatArray = x + b[None][..., list(self.stage.states)]
        if self.depth_rate is not None:
            y[..., self.stage.outputs.index(2)] = self.depth_rate.simulated(
                z_dot(*(self._path(x, x0, i) for i in (0, 1, 2, 6, 7))))
        return y

    def _path(self, x: FloatArray, x0: FloatArray, i: int) -> FloatArray:
        """State component ``i`` at rows 0..L, (L + 1, B, K): simulated (``x``, from
        ``x0``) or measured."""
        states = self.stage.states
        if i in states:
            return np.concatenate([x0[None, ..., i], x[..., states.index(i)]])
        return np.broadcast_to(self.exo[:, None, :, i], (x.shape[0] + 1, *x.shape[1:3]))

    def residuals(self, theta: FloatArray) -> FloatArray:
        """Weighted output errors (predicted − measured) where compared, flat, for one
        vector (P,)."""
        r: FloatArray = ((self.simulate(theta)[:, 0] - self.y) * self.weights).ravel()[
            self.compared]
        return r

    def jacobian(self, theta: FloatArray, free: Sequence[int], steps: FloatArray
                 ) -> tuple[FloatArray, FloatArray]:
        """:meth:`residuals` and their forward-difference Jacobian in the ``free``
        parameters with signed ``steps``: the base vector and every perturbed one in one
        batched simulation."""
        thetas = np.repeat(theta[None], len(free) + 1, axis=0)
        for j, i in enumerate(free):
            thetas[j + 1, i] += steps[j]
        y = self.simulate(thetas)
        base = (y[:, 0] - self.y) * self.weights                        # (L, K, n_out)
        dy = (y[:, 1:] - y[:, :1]) * (self.weights / np.asarray(steps)[:, None, None])
        J: FloatArray = np.moveaxis(dy, 1, -1).reshape(base.size, len(free))[self.compared]
        r: FloatArray = base.ravel()[self.compared]
        return r, J
