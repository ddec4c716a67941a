"""Experiments for dynamic identification: uniform time series of η, ν and τ.

An :class:`Experiment` is what the fit needs, whatever the source (a recorded session, a
replay, the simulator): sample times on a uniform grid, the pose η, the body velocity ν
and the commanded generalised force τ. :func:`experiments_from_samples` builds them from a
sample stream: the attitude samples are the time base (ATTITUDE is the fastest stream),
every other stream is zero-order held onto it (never interpolated, never looked ahead:
:func:`trimd.core.resample.zoh_align`), τ comes from the thruster PWM through the profile's
thrust curves and geometry at the reported battery voltage, and the stream is cut into
separate experiments wherever a stream has a gap.

Without a DVL (no body-velocity samples) the heave velocity comes from the depth sensor:
w = ż/(cos φ·cos θ), ż the derivative of a Savitzky–Golay fit of the depth (quadratic,
:data:`DEPTH_WINDOW_S`; smoothing, so it looks ahead by half the window), which is exact
where surge and sway are still or the vehicle level (ż = −sin θ·u + cos θ·sin φ·v +
cos θ·cos φ·w); surge and sway are unknown and recorded as 0 (the experiment says so:
``dvl`` False), and a fit leaves their parameters alone.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.signal import savgol_filter

from trimd.core.effort import tau_at
from trimd.core.errors import DataError
from trimd.core.profile import Profile
from trimd.core.resample import zoh_align
from trimd.core.samples import Attitude, Battery, Depth, Sample, Thrusters, Velocity

__all__ = ["DEPTH_WINDOW_S", "Experiment", "depth_rate", "experiments_from_samples",
           "heave_from_depth"]

FloatArray = NDArray[np.float64]

#: Held values older than this [s] are a gap, per stream: tighter than the static
#: estimate's limit (trimd.core.effort), since a fit integrates the held τ through time.
MAX_AGE_S = {"thrusters": 0.5, "velocity": 0.5, "depth": 1.0}
#: Window [s] of the Savitzky–Golay fit whose derivative is the depth rate without a DVL.
DEPTH_WINDOW_S = 0.3
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
    dvl : the body velocity was measured; False: u and v are unknown (0 here) and w comes
        from the depth rate (module docstring).
    """

    t_s: FloatArray
    eta: FloatArray
    nu: FloatArray
    tau: FloatArray
    label: str
    dvl: bool = True

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
        Without attitude or thruster samples, without both body-velocity (DVL) and depth
        samples, or when no piece of at least :data:`MIN_DURATION_S` has them all.
    """
    items = sorted(samples, key=lambda s: s.t_s)
    t_att, att = _series(items, Attitude, ("phi", "theta", "psi", "p", "q", "r"))
    thr = [s for s in items if isinstance(s, Thrusters)]
    t_vel, vel = _series(items, Velocity, ("u", "v", "w"))
    t_dep, dep = _series(items, Depth, ("depth_m",))
    dvl = len(t_vel) > 0
    for name, n in (("attitude", len(t_att)), ("thruster output", len(thr))):
        if n == 0:
            raise DataError(f"{label}: no {name} samples: identification needs attitude, "
                            "thruster outputs and body velocity (DVL) or depth")
    try:
        tau, have_tau = tau_at(profile, t_att, thr,
                               [s for s in items if isinstance(s, Battery)],
                               max_age_s=MAX_AGE_S["thrusters"])
    except DataError as exc:
        raise DataError(f"{label}: {exc}") from None
    held = (zoh_align(t_att, t_dep, dep[:, 0], max_age_s=MAX_AGE_S["depth"])
            if len(t_dep) else None)
    depth = held.values if held is not None else np.full(len(t_att), np.nan)
    # the stream that must be present: the DVL, or without one the depth sensor
    needed = zoh_align(t_att, t_vel, vel, max_age_s=MAX_AGE_S["velocity"]) if dvl else held
    if needed is None:
        raise DataError(f"{label}: no body velocity (DVL) or depth samples: identification "
                        "needs attitude, thruster outputs and body velocity or depth")
    velocity = needed.values if dvl else np.zeros((len(t_att), 3))
    valid = have_tau & needed.valid
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
        v = velocity[sl].copy()
        if not dvl:
            v[:, 2] = heave_from_depth(eta, h)
        out.append(Experiment(grid, eta, np.column_stack([v, att[sl, 3:]]), tau[sl],
                              f"{label}[{t[0]:.1f}–{t[-1]:.1f} s]", dvl))
    if not out:
        raise DataError(f"{label}: no stretch of at least {MIN_DURATION_S:g} s with attitude, "
                        f"thruster outputs and {'body velocity' if dvl else 'depth'} together")
    return out


def depth_rate(eta: FloatArray, h: float) -> FloatArray:
    """ż [m/s, down] from the depth of ``eta`` (N, 6) sampled every ``h`` [s]: the
    derivative of a Savitzky–Golay fit (quadratic) over :data:`DEPTH_WINDOW_S`."""
    n = len(eta)
    window = min(max(5, 2 * round(0.5 * DEPTH_WINDOW_S / h) + 1), n - (n + 1) % 2)
    z_dot: FloatArray = savgol_filter(eta[:, 2], window, 2, deriv=1, delta=h)
    return z_dot


def heave_from_depth(eta: FloatArray, h: float) -> FloatArray:
    """w [m/s] from the depth and attitude of ``eta`` (N, 6) sampled every ``h`` [s] as if
    surge and sway were still: ż/(cos φ·cos θ) (:func:`depth_rate`; module docstring)."""
    w: FloatArray = depth_rate(eta, h) / (np.cos(eta[:, 3]) * np.cos(eta[:, 4]))
    return w
