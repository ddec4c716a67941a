"""Experiments for dynamic identification: uniform time series of η, ν and τ.

An :class:`Experiment` is what the fit needs, whatever the source (a recorded session, a
replay, the simulator): sample times on a uniform grid, the pose η, the body velocity ν
and the commanded generalised force τ. :func:`experiments_from_samples` builds them from a
sample stream: the attitude samples are the time base (ATTITUDE is the fastest stream),
every other stream is zero-order held onto it (never interpolated, never looked ahead:
:func:`trimd.core.resample.zoh_align`), τ comes from the thruster PWM through the profile's
thrust curves and geometry at the reported battery voltage, and the stream is cut into
separate experiments wherever a stream has a gap.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trimd.core.effort import tau_at
from trimd.core.errors import DataError
from trimd.core.profile import Profile
from trimd.core.resample import zoh_align
from trimd.core.samples import Attitude, Battery, Depth, Sample, Thrusters, Velocity

__all__ = ["Experiment", "experiments_from_samples"]

FloatArray = NDArray[np.float64]

#: Held values older than this [s] are a gap, per stream: tighter than the static
#: estimate's limit (trimd.core.effort), since a fit integrates the held τ through time.
MAX_AGE_S = {"thrusters": 0.5, "velocity": 0.5, "depth": 1.0}
#: Pieces shorter than this [s] are dropped.
MIN_DURATION_S = 5.0


@dataclass(frozen=True, eq=False)
class Experiment:
    """One uninterrupted record on a uniform time grid.

    Attributes
    ----------
    t_s : sample times [s], shape (N,), step ``h_s``.
    eta : pose [n, e, d, φ, θ, ψ] [m, rad] (NED; n, e are NaN when unknown), (N, 6).
    nu : body velocity [u, v, w, p, q, r] [m/s, rad/s] (FRD), (N, 6).
    tau : commanded generalised force [X, Y, Z, K, M, N] [N, N·m] (FRD), held over
        [t_k, t_k + h), (N, 6).
    label : where it came from (file and piece), for reports.
    """

    t_s: FloatArray
    eta: FloatArray
    nu: FloatArray
    tau: FloatArray
    label: str

    def __post_init__(self) -> None:
        n = len(self.t_s)
        if n < 3 or any(a.shape != (n, 6) for a in (self.eta, self.nu, self.tau)):
            raise DataError(f"{self.label}: experiment arrays must be (N, 6) with N ≥ 3")
        dt = np.diff(self.t_s)
        if np.any(np.abs(dt - dt.mean()) > 0.25 * dt.mean()):
            raise DataError(f"{self.label}: sample times are not uniform")

    @property
    def h_s(self) -> float:
        """Sample interval [s]."""
        return float((self.t_s[-1] - self.t_s[0]) / (len(self.t_s) - 1))

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0])

    @property
    def x(self) -> FloatArray:
        """Measured model state [u, v, w, p, q, r, φ, θ], (N, 8)."""
        return np.concatenate([self.nu, self.eta[:, 3:5]], axis=1)


def _series(samples: list[Sample], kind: type, fields: tuple[str, ...]
            ) -> tuple[FloatArray, FloatArray]:
    rows = [s for s in samples if isinstance(s, kind)]
    t = np.array([s.t_s for s in rows], float)
    values = np.array([[getattr(s, f) for f in fields] for s in rows], float)
    return t, values.reshape(len(rows), len(fields))


def experiments_from_samples(samples: Iterable[Sample], profile: Profile, *,
                             label: str = "samples") -> list[Experiment]:
    """Cut a sample stream into experiments (module docstring).

    Raises
    ------
    DataError
        Without attitude, thruster or body-velocity (DVL) samples, or when no piece of at
        least :data:`MIN_DURATION_S` has all three.
    """
    items = sorted(samples, key=lambda s: s.t_s)
    t_att, att = _series(items, Attitude, ("phi", "theta", "psi", "p", "q", "r"))
    thr = [s for s in items if isinstance(s, Thrusters)]
    t_vel, vel = _series(items, Velocity, ("u", "v", "w"))
    t_dep, dep = _series(items, Depth, ("depth_m",))
    for name, n in (("attitude", len(t_att)), ("thruster output", len(thr)),
                    ("body velocity (DVL)", len(t_vel))):
        if n == 0:
            raise DataError(f"{label}: no {name} samples: identification needs attitude, "
                            "thruster outputs and body velocity")
    try:
        tau, have_tau = tau_at(profile, t_att, thr,
                               [s for s in items if isinstance(s, Battery)],
                               max_age_s=MAX_AGE_S["thrusters"])
    except DataError as exc:
        raise DataError(f"{label}: {exc}") from None
    nu = zoh_align(t_att, t_vel, vel, max_age_s=MAX_AGE_S["velocity"])
    depth = (zoh_align(t_att, t_dep, dep[:, 0], max_age_s=MAX_AGE_S["depth"]).values
             if len(t_dep) else np.full(len(t_att), np.nan))
    valid = have_tau & nu.valid
    h = float(np.median(np.diff(t_att))) if len(t_att) > 1 else 0.0
    breaks = np.flatnonzero(~valid | np.r_[True, np.diff(t_att) > 1.5 * h])
    out = []
    bounds = [*breaks.tolist(), len(t_att)]
    for a, b in itertools.pairwise(bounds):
        a = a if valid[a] else a + 1
        if b - a < 3 or t_att[b - 1] - t_att[a] < MIN_DURATION_S:
            continue
        sl = slice(a, b)
        eta = np.column_stack([np.full(b - a, np.nan), np.full(b - a, np.nan), depth[sl],
                               att[sl, :3]])
        t = t_att[sl]
        # a uniform grid: the attitude stamps jitter by at most a quarter step
        grid = t[0] + h * np.arange(b - a)
        out.append(Experiment(grid, eta, np.column_stack([nu.values[sl], att[sl, 3:]]),
                              tau[sl], f"{label}[{t[0]:.1f}–{t[-1]:.1f} s]"))
    if not out:
        raise DataError(f"{label}: no stretch of at least {MIN_DURATION_S:g} s with attitude, "
                        "thruster outputs and body velocity together")
    return out
