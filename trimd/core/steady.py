"""Steady-state detection in sample time (docs/method.md §3).

A sample is steady when, for every monitored channel (roll, pitch, depth, thruster
effort, …):

* the Cao–Rhinehart ratio of variances R = (2 − λ1)·ν²/δ² is below ``r_crit``
  (Cao & Rhinehart 1995, J. Process Control 5(6)); ν² is filtered about the *previous*
  filtered mean x_f[i−1];
* the drift over a trailing window (least-squares slope × window) is not both
  significant (a windowed slope t-test) and above the channel's practical floor
  ``drift_tol``;

and, when given, the attitude is within tolerance of its set-point and the body rates are
small. Steady samples that last at least ``min_duration_s`` form segments.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import lfilter

__all__ = [
    "RatioTest",
    "Segment",
    "SteadyCriteria",
    "detect_steady",
    "ratio_statistic",
    "steady_segments",
    "window_drift",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
_TINY = 1e-300


@dataclass(frozen=True)
class SteadyCriteria:
    """Thresholds of the detector; times in seconds of sample time.

    ``drift_tol`` is per channel, in the channel's units (drift allowed over
    ``window_s``); ``None`` skips the drift test. A gap between samples longer than
    ``max_gap_s`` restarts the detector: nothing is known about the gap. ``resolution``
    (per channel, channel units) is the quantisation step of the data, if any.
    """

    min_duration_s: float = 10.0
    window_s: float = 5.0
    r_crit: float = 2.5
    lambda1: float = 0.2
    lambda2: float = 0.1
    lambda3: float = 0.1
    drift_tol: tuple[float, ...] | None = None
    max_gap_s: float = 1.0
    resolution: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Segment:
    """Samples ``start:stop`` (stop exclusive), from ``t_start_s`` to ``t_end_s``."""

    start: int
    stop: int
    t_start_s: float
    t_end_s: float

    @property
    def duration_s(self) -> float:
        return self.t_end_s - self.t_start_s


def ratio_statistic(x: ArrayLike, lambda1: float = 0.2, lambda2: float = 0.1,
                    lambda3: float = 0.1, floor: ArrayLike = 0.0) -> FloatArray:
    """Cao–Rhinehart R for every sample of every column of ``x`` (shape (N,) or (N, k)).

    R ≈ 1 at steady state with white noise, R ≫ 1 in a transient. Where both variances
    are zero (a constant signal) R = 1. Filters start at x_f[0] = x[0], ν² = δ² = 0.
    ``floor`` (per column, in the signal's units squared) is added to both variances: a
    signal quantised to a resolution q (a log's 0.01°) flips by one step now and then,
    which the bare ratio reads as a transient; with floor ≈ q² such flips keep R ≈ 1.

    Examples
    --------
    >>> R = ratio_statistic(np.r_[np.zeros(50), np.linspace(0, 10, 50)] + 0.0)
    >>> bool(R[40] == 1.0), bool(R[-1] > 2.5)
    (True, True)
    """
    a = np.asarray(x, float)
    X = a.reshape(len(a), -1)
    zi = (1 - lambda1) * X[0]
    xf = lfilter([lambda1], [1.0, lambda1 - 1.0], X, axis=0, zi=zi[None, :])[0]
    xf_prev = np.vstack([X[:1], xf[:-1]])
    nu2 = lfilter([lambda2], [1.0, lambda2 - 1.0], (X - xf_prev) ** 2, axis=0)
    d = np.vstack([np.zeros((1, X.shape[1])), np.diff(X, axis=0)])
    delta2 = lfilter([lambda3], [1.0, lambda3 - 1.0], d * d, axis=0)
    nu2, delta2 = nu2 + np.asarray(floor, float), delta2 + np.asarray(floor, float)
    R = np.where((nu2 < _TINY) & (delta2 < _TINY), 1.0,
                 (2 - lambda1) * nu2 / np.maximum(delta2, _TINY))
    return R.reshape(a.shape)


class RatioTest:
    """Streaming Cao–Rhinehart test for a procedure that sees one sample at a time.

    Gives the same R as :func:`ratio_statistic` on the same sequence.
    """

    def __init__(self, lambda1: float = 0.2, lambda2: float = 0.1, lambda3: float = 0.1):
        self.l1, self.l2, self.l3 = lambda1, lambda2, lambda3
        self._x: FloatArray | None = None
        self._xf: FloatArray | None = None
        self._nu2: FloatArray | None = None
        self._delta2: FloatArray | None = None
        self.count = 0

    def update(self, x: ArrayLike) -> FloatArray:
        """Add one sample (a value per channel); return R per channel."""
        v = np.atleast_1d(np.asarray(x, float))
        if self._x is None or self._xf is None or self._nu2 is None or self._delta2 is None:
            self._x, self._xf = v.copy(), v.copy()
            self._nu2, self._delta2 = np.zeros_like(v), np.zeros_like(v)
        else:
            self._nu2 = self.l2 * (v - self._xf) ** 2 + (1 - self.l2) * self._nu2
            self._delta2 = self.l3 * (v - self._x) ** 2 + (1 - self.l3) * self._delta2
            self._xf = self.l1 * v + (1 - self.l1) * self._xf
            self._x = v.copy()
        self.count += 1
        both_zero = (self._nu2 < _TINY) & (self._delta2 < _TINY)
        R: FloatArray = np.where(both_zero, 1.0, (2 - self.l1) * self._nu2
                                 / np.maximum(self._delta2, _TINY))
        return R


def window_drift(t: ArrayLike, x: ArrayLike, window_s: float, t_crit: float = 3.0
                 ) -> FloatArray:
    """Significant drift over the trailing ``window_s`` [s] of every sample.

    The least-squares slope b over the window, times the window: |b|·window where the
    slope is significant (|b| > ``t_crit``·se(b), a windowed slope t-test), else 0. Shapes
    as :func:`ratio_statistic`; units of ``x``. Running sums, O(N).
    """
    ts = np.asarray(t, float)
    a = np.asarray(x, float)
    X = a.reshape(len(a), -1)
    tc = (ts - ts[0])[:, None]
    X0 = X - X[0]

    def windowed(v: FloatArray) -> FloatArray:
        c = np.concatenate([np.zeros((1, *v.shape[1:])), np.cumsum(v, axis=0)])
        sums: FloatArray = c[1:] - c[np.searchsorted(ts, ts - window_s, side="left")]
        return sums

    n = windowed(np.ones_like(tc))
    St, Stt = windowed(tc), windowed(tc * tc)
    Sx, Sxx, Stx = windowed(X0), windowed(X0 * X0), windowed(tc * X0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tt = Stt - St * St / n
        tx = Stx - St * Sx / n
        xx = Sxx - Sx * Sx / n
        slope = np.where(tt > 1e-12, tx / tt, 0.0)
        sse = np.maximum(xx - slope * tx, 0.0)
        se = np.sqrt(np.where((n > 2) & (tt > 1e-12), sse / (n - 2) / tt, np.inf))
    significant = np.abs(slope) > t_crit * se
    drift: FloatArray = np.where(significant, np.abs(slope) * window_s, 0.0)
    return drift.reshape(a.shape)


def steady_segments(t: ArrayLike, mask: ArrayLike, min_duration_s: float) -> list[Segment]:
    """Runs of True in ``mask`` lasting at least ``min_duration_s`` [s]."""
    ts = np.asarray(t, float)
    m = np.asarray(mask, bool)
    edges = np.flatnonzero(np.diff(np.r_[0, m.astype(np.int8), 0]))
    segments = []
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        seg = Segment(int(start), int(stop), float(ts[start]), float(ts[stop - 1]))
        if seg.duration_s >= min_duration_s:
            segments.append(seg)
    return segments


def _steady_chunk(t: FloatArray, X: FloatArray, criteria: SteadyCriteria) -> BoolArray:
    """Steady mask of one gap-free stretch from the R and drift tests."""
    floor = 0.0 if criteria.resolution is None else np.square(criteria.resolution)
    mask = np.all(ratio_statistic(X, criteria.lambda1, criteria.lambda2, criteria.lambda3,
                                  floor) < criteria.r_crit, axis=1)
    mask[: int(np.ceil(3 / criteria.lambda2))] = False
    if criteria.drift_tol is not None:
        tol = np.asarray(criteria.drift_tol, float)
        mask &= np.all(window_drift(t, X, criteria.window_s) <= tol, axis=1)
        mask &= t - t[0] >= criteria.window_s
    result: BoolArray = mask
    return result


def detect_steady(t: ArrayLike, signals: ArrayLike, criteria: SteadyCriteria, *,
                  attitude_error_rad: ArrayLike | None = None,
                  attitude_tol_rad: float = np.inf,
                  rates_rad_s: ArrayLike | None = None,
                  rate_tol_rad_s: float = np.inf) -> tuple[BoolArray, list[Segment]]:
    """Steady mask and segments of ``signals`` (shape (N, k)) on sample times ``t`` [s].

    Parameters
    ----------
    attitude_error_rad : optional (N, m) difference to the set-point [rad].
    rates_rad_s : optional (N, 3) body rates [rad/s].

    The first ``3/λ2`` samples after the start or a gap are never steady (the filters
    are still starting), nor are non-finite samples.
    """
    ts = np.asarray(t, float)
    X = np.asarray(signals, float).reshape(len(ts), -1)
    mask = np.zeros(len(ts), dtype=bool)
    breaks = np.flatnonzero(np.diff(ts) > criteria.max_gap_s) + 1
    for start, stop in zip(np.r_[0, breaks], np.r_[breaks, len(ts)], strict=True):
        if stop - start > 2:
            mask[start:stop] = _steady_chunk(ts[start:stop], X[start:stop], criteria)
    for values, limit in ((attitude_error_rad, attitude_tol_rad),
                          (rates_rad_s, rate_tol_rad_s)):
        if values is not None:
            v = np.asarray(values, float).reshape(len(ts), -1)
            mask &= np.all(np.abs(v) <= limit, axis=1)
    mask &= np.all(np.isfinite(X), axis=1)
    segments = [seg for start, stop in zip(np.r_[0, breaks], np.r_[breaks, len(ts)],
                                           strict=True)
                for seg in _offset(steady_segments(ts[start:stop], mask[start:stop],
                                                   criteria.min_duration_s), int(start))]
    return mask, segments


def _offset(segments: list[Segment], start: int) -> list[Segment]:
    return [Segment(s.start + start, s.stop + start, s.t_start_s, s.t_end_s) for s in segments]
