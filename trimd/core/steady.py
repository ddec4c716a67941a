"""The steady-state tests of one stream, in sample time (docs/method.md §3 "Steady state").

* the Cao–Rhinehart ratio of variances R = (2 − λ1)·ν²/δ² (Cao & Rhinehart 1995, J.
  Process Control 5(6)), near 1 at steady state and well above in a transient; ν² is
  filtered about the *previous* filtered mean x_f[i−1]: :func:`ratio_statistic` over a
  whole series, :class:`RatioTest` one sample at a time;
* the significant drift over a trailing window (least-squares slope × window, where a
  windowed slope t-test finds the slope significant): :func:`window_drift`.

The live settling test (:mod:`trimd.core.settling`) combines them per channel; the hold
finder of logs (:mod:`trimd.core.holdfinder`) runs that same test.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from trimd.core.types import FloatArray

__all__ = ["RatioTest", "last_window_drift", "ratio_statistic", "window_drift"]

_TINY = 1e-300


def ratio_statistic(x: ArrayLike, lambda1: float = 0.2, lambda2: float = 0.1,
                    lambda3: float = 0.1) -> FloatArray:
    """Cao–Rhinehart R for every sample of every column of ``x`` (shape (N,) or (N, k)).

    R ≈ 1 at steady state with white noise, R ≫ 1 in a transient. Where both variances
    are zero (a constant signal) R = 1. Filters start at x_f[0] = x[0], ν² = δ² = 0.

    Examples
    --------
    >>> R = ratio_statistic(np.r_[np.zeros(50), np.linspace(0, 10, 50)] + 0.0)
    >>> bool(R[40] == 1.0), bool(R[-1] > 2.5)
    (True, True)
    """
    from scipy.signal import lfilter  # 1 s to import: only for a whole series

    a = np.asarray(x, float)
    X = a.reshape(len(a), -1)
    zi = (1 - lambda1) * X[0]
    xf = lfilter([lambda1], [1.0, lambda1 - 1.0], X, axis=0, zi=zi[None, :])[0]
    xf_prev = np.vstack([X[:1], xf[:-1]])
    nu2 = lfilter([lambda2], [1.0, lambda2 - 1.0], (X - xf_prev) ** 2, axis=0)
    d = np.vstack([np.zeros((1, X.shape[1])), np.diff(X, axis=0)])
    delta2 = lfilter([lambda3], [1.0, lambda3 - 1.0], d * d, axis=0)
    R = np.where((nu2 < _TINY) & (delta2 < _TINY), 1.0,
                 (2 - lambda1) * nu2 / np.maximum(delta2, _TINY))
    return R.reshape(a.shape)


class RatioTest:
    """Streaming Cao–Rhinehart test for a procedure that sees one sample at a time.

    Gives the same R as :func:`ratio_statistic` on the same sequence.
    """

    def __init__(self, lambda1: float = 0.2, lambda2: float = 0.1, lambda3: float = 0.1):
        self.l1, self.l2, self.l3 = lambda1, lambda2, lambda3
        # the filters' state per channel, in Python floats: a sample's few channels cost
        # less so than as arrays (the settling test's hot path), with the same arithmetic
        self._x: list[float] = []
        self._xf: list[float] = []
        self._nu2: list[float] = []
        self._delta2: list[float] = []
        self.count = 0

    def update(self, x: ArrayLike) -> list[float]:
        """Add one sample (a value per channel); return R per channel."""
        v: list[float] = np.atleast_1d(np.asarray(x, float)).tolist()
        if not self.count:
            self._x, self._xf = v, list(v)
            self._nu2, self._delta2 = [0.0] * len(v), [0.0] * len(v)
        else:
            l1, l2, l3 = self.l1, self.l2, self.l3
            self._nu2 = [l2 * ((a - f) * (a - f)) + (1 - l2) * n
                         for a, f, n in zip(v, self._xf, self._nu2, strict=True)]
            self._delta2 = [l3 * ((a - b) * (a - b)) + (1 - l3) * d
                            for a, b, d in zip(v, self._x, self._delta2, strict=True)]
            self._xf = [l1 * a + (1 - l1) * f for a, f in zip(v, self._xf, strict=True)]
            self._x = v
        self.count += 1
        return [1.0 if n < _TINY and d < _TINY else (2 - self.l1) * n / max(d, _TINY)
                for n, d in zip(self._nu2, self._delta2, strict=True)]


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
    return _drift(n, St, Stt, Sx, Sxx, Stx, window_s, t_crit).reshape(a.shape)


def _drift(n: FloatArray, St: FloatArray, Stt: FloatArray, Sx: FloatArray, Sxx: FloatArray,
           Stx: FloatArray, window_s: float, t_crit: float) -> FloatArray:
    """The significant drift over ``window_s`` of each channel from the window's running
    sums (count, Σt, Σt², Σx, Σx², Σtx): |slope|·window where the least-squares slope
    exceeds ``t_crit`` standard errors, else 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tt = Stt - St * St / n
        tx = Stx - St * Sx / n
        xx = Sxx - Sx * Sx / n
        slope = np.where(tt > 1e-12, tx / tt, 0.0)
        sse = np.maximum(xx - slope * tx, 0.0)
        se = np.sqrt(np.where((n > 2) & (tt > 1e-12), sse / (n - 2) / tt, np.inf))
    significant = np.abs(slope) > t_crit * se
    drift: FloatArray = np.where(significant, np.abs(slope) * window_s, 0.0)
    return drift


def last_window_drift(t: FloatArray, X: FloatArray, window_s: float, t_crit: float = 3.0
                      ) -> FloatArray:
    """:func:`window_drift` of the last sample alone (``t`` (N,), ``X`` (N, k)): the
    live test's question, sample by sample. Equal bit for bit to
    ``window_drift(t, X, window_s, t_crit)[-1]`` (the same running sums, the same
    arithmetic, on the last row only)."""
    tc = (t - t[0])[:, None]
    X0 = X - X[0]
    k = X.shape[1]
    j = int(np.searchsorted(t, t[-1] - window_s, side="left"))
    # every running sum in one cumsum (column by column, the same additions in order)
    c = np.cumsum(np.hstack([np.ones_like(tc), tc, tc * tc, X0, X0 * X0, tc * X0]), axis=0)
    sums = c[-1] - (c[j - 1] if j > 0 else 0.0)
    n, St, Stt = sums[0:1], sums[1:2], sums[2:3]
    Sx, Sxx, Stx = sums[3:3 + k], sums[3 + k:3 + 2 * k], sums[3 + 2 * k:]
    return _drift(n, St, Stt, Sx, Sxx, Stx, window_s, t_crit)
