"""The heave output of a fit without a DVL: the depth rate as the depth sensor shows it.

Without body velocity the heave velocity in an experiment is derived from the depth: the
derivative of a Savitzky–Golay fit over :data:`trimd.identify.data.DEPTH_WINDOW_S`
(:func:`trimd.identify.data.depth_rate`). That filter smooths: the derived w rises later
and rounder after each thrust step than the true one, and a fit comparing the simulated w
with it lengthened the thruster lag to match, which the inertia of a fast DOF trades
against (docs/identification.md, "Without a DVL"). :class:`DepthRate` compares like with
like: the simulated depth rate (:func:`trimd.identify.data.z_dot`) of each segment is
integrated to a depth, kept at the depth sensor's samples and interpolated linearly
between them as the measured depth is, and differentiated by the same filter; the
measured depth of the segment goes through the same steps. Samples within half a filter
window of a segment's ends (where the filter would see past the segment) are not
compared. Validation does the same for one free run
(:func:`trimd.identify.validation.validate`, with a wider window).

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from trimd.core.types import FloatArray
from trimd.identify.data import Experiment, depth_window

__all__ = ["DepthRate"]



class DepthRate:
    """The depth sensor's view of a fit's segments (module docstring).

    Parameters
    ----------
    experiments : the fit's experiments (``dvl`` False: the depth is the heave measurement).
    rows : sample index (into the experiments concatenated) of every step of every
        segment, (L + 1, K); each segment starts at a depth sample.
    step : time between rows [s].

    Attributes
    ----------
    measured : the measured depth rate through the filter at rows 1..L, (L, K).
    compared : where it is compared: depth samples at least half a window inside the
        segment, (L, K).
    """

    def __init__(self, experiments: Sequence[Experiment], rows: NDArray[np.intp],
                 step: float) -> None:
        depth = np.concatenate([e.eta[:, 2] for e in experiments])[rows]      # (L+1, K)
        fresh = np.concatenate([e.measured[:, 2] for e in experiments])[rows]
        n = rows.shape[0]
        self.window = depth_window(n, step, max(e.interval_s(2) for e in experiments))
        self.step = step
        # linear interpolation between the depth samples of each segment (held at the end)
        index = np.arange(n)[:, None] * np.ones((1, rows.shape[1]), np.intp)
        self._prev = np.maximum.accumulate(np.where(fresh, index, 0), axis=0)
        after = np.where(fresh, index, n)
        nxt = np.minimum.accumulate(after[::-1], axis=0)[::-1]
        self._next = np.where(nxt == n, self._prev, nxt)
        gap = (self._next - self._prev).astype(float)
        self._a = np.divide(index - self._prev, gap, out=np.zeros_like(gap), where=gap > 0)
        self.measured = self._filtered(depth[:, None])[1:, 0]
        half = self.window // 2
        inside = np.zeros(n, bool)
        inside[half:n - half] = True
        self.compared = (fresh & inside[:, None])[1:]

    def _filtered(self, z: FloatArray) -> FloatArray:
        """Depth (L + 1, B, K) kept at the depth samples, interpolated between them and
        differentiated by the filter: (L + 1, B, K) [m/s]."""
        from scipy.signal import savgol_filter  # 1 s to import: not for every identify import

        prev = np.take_along_axis(z, self._prev[:, None, :], axis=0)
        nxt = np.take_along_axis(z, self._next[:, None, :], axis=0)
        held = prev + self._a[:, None, :] * (nxt - prev)
        # the ends (mode "nearest": a plain convolution, NaN-safe for a diverged trial) are
        # never compared
        out: FloatArray = savgol_filter(held, self.window, 2, deriv=1, delta=self.step,
                                        axis=0, mode="nearest")
        return out

    def simulated(self, zdot: FloatArray) -> FloatArray:
        """The simulated depth rate ``zdot`` at rows 0..L, (L + 1, B, K), as the depth
        sensor and the filter show it at rows 1..L, (L, B, K): integrated (trapezoid) to a
        depth from the segment's start, then as the measured depth."""
        with np.errstate(over="ignore", invalid="ignore"):
            z = np.concatenate([np.zeros_like(zdot[:1]),
                                np.cumsum(0.5 * self.step * (zdot[1:] + zdot[:-1]), axis=0)])
            return self._filtered(z)[1:]
