"""Experiments for dynamic identification: uniform time series of η, ν and τ.

An :class:`Experiment` is what the fit needs, whatever the source (a recorded session, a
replay, the simulator): sample times on a uniform grid, the pose η, the body velocity ν,
the commanded generalised force τ, and where each state component was measured.
:func:`experiments_from_samples` builds them from a sample stream: the attitude samples
are the time base (ATTITUDE is the fastest stream); τ comes from the thruster PWM through
the profile's thrust curves and geometry at the reported battery voltage, zero-order held
onto the grid (a command holds until the next; when it changed within the thruster
stream's interval the fit's lead ``T_lead`` estimates); the body velocity and the depth
are slower streams (a DVL and a depth sensor at 5 Hz beside attitude at 20 Hz), linearly
interpolated between their own samples onto the grid — the interpolated values only start
and drive the simulation, and ``fresh`` marks the grid times that are samples of their own
stream (within half a grid step), the only times a fit or a validation compares that
output (never a held or interpolated repeat). The stream is cut into separate experiments
wherever a stream has a gap.

Without a DVL (no body-velocity samples) the heave velocity comes from the depth sensor:
w = ż/(cos φ·cos θ), ż the derivative of a Savitzky–Golay fit of the depth (quadratic,
:data:`DEPTH_WINDOW_S`, at least :data:`DEPTH_WINDOW_SAMPLES` depth samples; smoothing, so
it looks ahead by half the window), which is exact where surge and sway are still or the
vehicle level (ż = −sin θ·u + cos θ·sin φ·v + cos θ·cos φ·w); surge and sway are unknown
and recorded as 0 (the experiment says so: ``dvl`` False), and a fit leaves their
parameters alone.
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
from trimd.core.types import FloatArray

__all__ = ["DEPTH_WINDOW_S", "DEPTH_WINDOW_SAMPLES", "Experiment", "depth_rate", "depth_window",
           "experiments_from_samples", "heave_from_depth", "z_dot"]


#: Held values older than this [s] are a gap, per stream: tighter than the static
#: estimate's limit (trimd.core.effort), since a fit integrates the held τ through time.
MAX_AGE_S = {"thrusters": 0.5, "velocity": 0.5, "depth": 1.0}
#: Window [s] of the Savitzky–Golay fit whose derivative is the depth rate without a DVL.
DEPTH_WINDOW_S = 0.3
#: ... spanning at least this many samples of the depth stream.
DEPTH_WINDOW_SAMPLES = 2
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
    fresh : per sample and state component of :attr:`x` ([u, v, w, p, q, r, φ, θ]), True
        where it is a sample of its own stream (module docstring), (N, 8); None: all are.
    thruster_h_s : sample interval of the thruster record [s] (None: the grid's): how far
        a command may have changed before the sample that first shows it.
    """

    t_s: FloatArray
    eta: FloatArray
    nu: FloatArray
    tau: FloatArray
    label: str
    dvl: bool = True
    fresh: NDArray[np.bool_] | None = None
    thruster_h_s: float | None = None

    def __post_init__(self) -> None:
        n = len(self.t_s)
        if n < 3 or any(a.shape != (n, 6) for a in (self.eta, self.nu, self.tau)):
            raise DataError(f"{self.label}: experiment arrays must be (N, 6) with N ≥ 3")
        if self.fresh is not None and self.fresh.shape != (n, 8):
            raise DataError(f"{self.label}: the fresh mask must be (N, 8)")
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

    @property
    def measured(self) -> NDArray[np.bool_]:
        """Where each component of :attr:`x` is a sample of its own stream, (N, 8)."""
        return np.ones((len(self.t_s), 8), bool) if self.fresh is None else self.fresh

    def interval_s(self, component: int) -> float:
        """Median interval [s] between the samples of state component ``component`` of
        :attr:`x` (the grid step when every grid time is one)."""
        k = np.flatnonzero(self.measured[:, component])
        return self.h_s * float(np.median(np.diff(k))) if len(k) > 1 else self.h_s

    @property
    def lead_max_s(self) -> float:
        """Largest lead of the thruster record over the motion [s]: a command may have
        changed anywhere within the thruster record's interval before the sample that
        shows it, which the zero-order hold onto the grid delays by up to one more step."""
        return self.h_s + max(self.h_s, self.thruster_h_s or 0.0)


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
    h = float(np.median(np.diff(t_att))) if len(t_att) > 1 else 0.0
    held = (zoh_align(t_att, t_dep, dep[:, 0], max_age_s=MAX_AGE_S["depth"])
            if len(t_dep) else None)
    depth = _between(t_att, t_dep, dep) if held is not None else np.full((len(t_att), 1),
                                                                         np.nan)
    # the stream that must be present: the DVL, or without one the depth sensor
    needed = zoh_align(t_att, t_vel, vel, max_age_s=MAX_AGE_S["velocity"]) if dvl else held
    if needed is None:
        raise DataError(f"{label}: no body velocity (DVL) or depth samples: identification "
                        "needs attitude, thruster outputs and body velocity or depth")
    velocity = _between(t_att, t_vel, vel) if dvl else np.zeros((len(t_att), 3))
    fresh = np.ones((len(t_att), 8), bool)
    fresh[:, :3] = _sampled(t_att, t_vel if dvl else t_dep, h)[:, None]
    if not dvl:
        fresh[:, :2] = False     # u and v are not measured at all
    t_thr = np.array([s.t_s for s in thr], float)
    thruster_h = float(np.median(np.diff(t_thr))) if len(t_thr) > 1 else None
    valid = have_tau & needed.valid
    breaks = np.flatnonzero(~valid | np.r_[True, np.diff(t_att) > 1.5 * h])
    out = []
    bounds = [*breaks.tolist(), len(t_att)]
    for a, b in itertools.pairwise(bounds):
        a = a if valid[a] else a + 1
        if b - a < 3 or t_att[b - 1] - t_att[a] < MIN_DURATION_S:
            continue
        sl = slice(a, b)
        eta = np.column_stack([np.full(b - a, np.nan), np.full(b - a, np.nan),
                               depth[sl, 0], att[sl, :3]])
        t = t_att[sl]
        # a uniform grid: the attitude stamps jitter by at most a quarter step
        grid = t[0] + h * np.arange(b - a)
        v = velocity[sl].copy()
        if not dvl:
            v[:, 2] = heave_from_depth(eta, h, _interval(t_dep))
        out.append(Experiment(grid, eta, np.column_stack([v, att[sl, 3:]]), tau[sl],
                              f"{label}[{t[0]:.1f}–{t[-1]:.1f} s]", dvl, fresh[sl],
                              thruster_h))
    if not out:
        raise DataError(f"{label}: no stretch of at least {MIN_DURATION_S:g} s with attitude, "
                        f"thruster outputs and {'body velocity' if dvl else 'depth'} together")
    return out


def _interval(t: FloatArray) -> float:
    """Median sample interval [s] of a stream's times (0 for fewer than two)."""
    return float(np.median(np.diff(t))) if len(t) > 1 else 0.0


def _between(t_ref: FloatArray, t_src: FloatArray, values: FloatArray) -> FloatArray:
    """``values`` (M, k) sampled at ``t_src`` linearly interpolated onto ``t_ref`` (held
    flat beyond the ends), (N, k)."""
    return np.column_stack([np.interp(t_ref, t_src, values[:, j])
                            for j in range(values.shape[1])])


def _sampled(t_ref: FloatArray, t_src: FloatArray, h: float) -> NDArray[np.bool_]:
    """True at the reference times within h/2 of a sample of the stream at ``t_src``."""
    if len(t_src) == 0:
        return np.zeros(len(t_ref), bool)
    idx = np.clip(np.searchsorted(t_src, t_ref), 1, max(len(t_src) - 1, 1))
    nearest = np.minimum(np.abs(t_ref - t_src[idx - 1]), np.abs(t_src[idx] - t_ref))
    out: NDArray[np.bool_] = nearest <= 0.5 * h + 1e-9
    return out


def depth_rate(eta: FloatArray, h: float, depth_h_s: float = 0.0,
               samples: int = DEPTH_WINDOW_SAMPLES) -> FloatArray:
    """ż [m/s, down] from the depth of ``eta`` (N, 6) on a grid of step ``h`` [s], the depth
    sensor sampling every ``depth_h_s`` [s] (0: every grid step): the derivative of a
    Savitzky–Golay fit (quadratic) over :data:`DEPTH_WINDOW_S` and at least ``samples``
    depth samples."""
    from scipy.signal import savgol_filter  # 1 s to import: not for every identify import

    window = depth_window(len(eta), h, depth_h_s, samples)
    z_dot: FloatArray = savgol_filter(eta[:, 2], window, 2, deriv=1, delta=h)
    return z_dot


def depth_window(n: int, h: float, depth_h_s: float = 0.0,
                 samples: int = DEPTH_WINDOW_SAMPLES) -> int:
    """Samples (odd, at least 5, at most ``n``) of the Savitzky–Golay window of
    :func:`depth_rate` on ``n`` samples of step ``h`` [s]: :data:`DEPTH_WINDOW_S` and at
    least ``samples`` samples of a depth sensor sampling every ``depth_h_s`` [s]."""
    span = max(DEPTH_WINDOW_S, samples * depth_h_s)
    return min(max(5, 2 * round(0.5 * span / h) + 1), n - (n + 1) % 2)


def z_dot(u: FloatArray, v: FloatArray, w: FloatArray, phi: FloatArray, theta: FloatArray
          ) -> FloatArray:
    """Depth rate [m/s, NED down] of body velocity u, v, w [m/s] at roll and pitch φ, θ
    [rad] (Fossen eq. 2.19, third row; :func:`heave_from_depth` inverts it at u = v = 0)."""
    ct = np.cos(theta)
    out: FloatArray = -np.sin(theta) * u + ct * np.sin(phi) * v + ct * np.cos(phi) * w
    return out


def heave_from_depth(eta: FloatArray, h: float, depth_h_s: float = 0.0) -> FloatArray:
    """w [m/s] from the depth and attitude of ``eta`` (N, 6) as if surge and sway were
    still: ż/(cos φ·cos θ) (:func:`depth_rate`, same arguments; module docstring)."""
    w: FloatArray = depth_rate(eta, h, depth_h_s) / (np.cos(eta[:, 3]) * np.cos(eta[:, 4]))
    return w
