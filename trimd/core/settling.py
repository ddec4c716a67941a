"""Has a commanded attitude hold settled? The live test, one sample at a time.

A hold has settled when the attitude is at its set-point within ``attitude_tol_deg``, the
body rates are below ``rate_tol_deg_s``, and the Cao–Rhinehart ratio test
(:class:`trimd.core.steady.RatioTest`) is settled on attitude and on thruster effort, each
stream on its own samples (a zero-order-held, repeated value would inflate the ratio).
Effort also counts as settled when it does not drift by more than a practical floor over
a trailing window: a row stuck in the thrusters' deadband that pops out now and then (the
T200's limit cycle) fails the ratio test but is steady in the mean. The statistical tests
have false alarms (a few % of samples each), so a failure unsettles the hold only when it
lasts longer than :data:`UNSTEADY_GRACE_S`; leaving the attitude tolerance, or stale
thruster data, unsettles at once. Time is the samples' own [s].
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import NDArray

from trimd.core.profile import ProcedureLimits
from trimd.core.samples import Attitude
from trimd.core.steady import RatioTest, window_drift

__all__ = ["EFFORT_WINDOW_S", "UNSTEADY_GRACE_S", "HoldSettling"]

#: A failed steadiness test unsettles a hold only when it persists this long [s].
UNSTEADY_GRACE_S = 1.0
#: Trailing window [s] of the thruster-effort drift test.
EFFORT_WINDOW_S = 5.0
#: Samples each ratio test needs before it can call a stream settled.
MIN_RATIO_SAMPLES = 12
#: The Cao–Rhinehart ratio below which a stream is steady.
R_CRIT = 2.5


class HoldSettling:
    """The settling state of one hold at set-point (``phi``, ``theta``) [rad].

    ``floor`` is the effort drift [N, N·m per row of τ] below which effort counts as
    steady: what would move the estimate by its target standard deviation.
    """

    def __init__(self, limits: ProcedureLimits, phi: float, theta: float,
                 floor: NDArray[np.float64]) -> None:
        self.phi, self.theta = phi, theta
        self.tol = math.radians(limits.attitude_tol_deg)
        self.rate_tol = math.radians(limits.rate_tol_deg_s)
        self.floor = floor
        self.steady_since = math.nan
        self._unsteady_since = math.nan
        self._ratio_att = RatioTest()
        self._ratio_tau = RatioTest()
        self._tau_window: deque[tuple[float, NDArray[np.float64]]] = deque()
        self._tau_settled = False

    def effort(self, t_s: float, tau: NDArray[np.float64]) -> None:
        """A new thruster-effort sample τ [N, N·m] at ``t_s``."""
        R = self._ratio_tau.update(tau)
        window = self._tau_window
        window.append((t_s, tau))
        while window and window[0][0] < t_s - EFFORT_WINDOW_S:
            window.popleft()
        if self._ratio_tau.count <= MIN_RATIO_SAMPLES or t_s - window[0][0] < 0.9 * EFFORT_WINDOW_S:
            self._tau_settled = False
            return
        t = np.array([w[0] for w in window])
        drift = window_drift(t, np.array([w[1] for w in window]), EFFORT_WINDOW_S)[-1]
        self._tau_settled = bool(np.all((R < R_CRIT) | (drift <= self.floor)))

    def in_tolerance(self, a: Attitude) -> bool:
        return abs(a.phi - self.phi) <= self.tol and abs(a.theta - self.theta) <= self.tol

    def attitude(self, a: Attitude, have_tau: bool) -> bool:
        """A new attitude sample; is the hold settled now? ``have_tau``: fresh thruster
        outputs are held at this sample."""
        if not have_tau or not self.in_tolerance(a):
            self.steady_since = self._unsteady_since = math.nan
            self._steady(a)
            return False
        if self._steady(a):
            self._unsteady_since = math.nan
            if math.isnan(self.steady_since):
                self.steady_since = a.t_s
        elif math.isnan(self._unsteady_since):
            self._unsteady_since = a.t_s
        elif a.t_s - self._unsteady_since > UNSTEADY_GRACE_S:
            self.steady_since = math.nan
        return not math.isnan(self.steady_since)

    def _steady(self, a: Attitude) -> bool:
        R = self._ratio_att.update([a.phi, a.theta])
        return (self.in_tolerance(a) and max(abs(a.p), abs(a.q)) <= self.rate_tol
                and self._tau_settled and self._ratio_att.count > MIN_RATIO_SAMPLES
                and bool(np.all(R < R_CRIT)))
