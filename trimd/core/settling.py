"""Has a commanded attitude hold settled? The live test, one sample at a time.

A hold has settled when the attitude is at its set-point within ``attitude_tol_deg`` and
its roll and pitch rates are below ``rate_tol_deg_s`` (both judged by their mean over
:data:`RATE_WINDOW_S`), and two streams are steady, each on its own samples (a
zero-order-held, repeated value would distort both tests): the attitude (roll, pitch) and
the thruster effort τ. The rates are the Euler angles' (:func:`euler_rates`), not the
body rates p, q: at a tilt, a vehicle turning in yaw has body rates p and q while its roll
and pitch stay put (the simulated small-payload BlueROV2 Heavy at 20°/20°, its yaw hunting
±10°/s in its horizontal thrusters' dead band, had 3–5°/s of body p and q, and its
tilted hold never settled in 5 of 200 trims). A stream is steady on a channel when the
Cao–Rhinehart ratio test (:class:`trimd.core.steady.RatioTest`) finds no transient, *or*
the channel does not drift by more than a practical floor over a trailing window
(:func:`trimd.core.steady.window_drift`).

The ratio test alone reads any coloured signal as a transient: slow attitude wander (an
AHRS at rest, a held set-point wandering by 0.1–0.3° over 10–20 s), PWM dither on
thrusters at the edge of their deadband and the limit cycles it drives, or a noise-free
hold sitting in a tiny deterministic cycle (measured on the simulated BlueROV2 Heavy with
``disturb=real``: the roll ratio above 2.5 for 95 % of the samples of a steady hold, so
the hold never settled). The estimator's long-run variance already accounts for these, so
they must not keep a hold from settling; the drift floor lets them through. The floors:

- effort: what would not matter to the decision (:meth:`trimd.core.decision.StopRule.
  effort_floor`, infinite on rows that carry no information at the hold's attitude);
- attitude: :data:`ATTITUDE_DRIFT_SHARE` of ``attitude_tol_deg`` per window. Wander of
  the held attitude drifts 0.2–0.6° per 5 s window on the Heavy (95th percentile), while
  an approach to the set-point still under way (the Heavy's tilted hold creeps its last
  1.5–2° in over ≈ 10 s as the integrators wind up) drifts more.

Wander driven by disturbance torques that the thrusters fight (waves, a tether, current on
the frame) is another matter: the attitude wanders at the loop's own time scale while the
effort wanders by nearly the whole torque, tens of times what the decision floor allows
(the simulated Sabertooth with 0.2° RMS of such wander at a 20 s correlation: roll and
pitch effort 30–130 N·m RMS against a floor of ≈ 4 N·m), so no drift floor on effort can
let it through. Where the attitude loop is weak (the Heavy inside its thrusters' dead
band) the attitude itself wanders by as much as the tolerance: the same torques leave
0.4–1.1° RMS there, drifting 1–2° per window and crossing a 1.5° tolerance for seconds at
a time, so neither the attitude's drift floor nor a tolerance on each sample lets such a
hold settle (issue 22: 7 of 80 Heavy trims at 0.2° never settled a hold). What does:

- each drift test looks over a short window (:data:`WINDOW_S`) *and* a long one
  (:data:`LONG_WINDOW_S`), and a channel is steady when either stays within its floor: fast
  wander averages out over the long window, slow wander barely moves over the short one,
  while an approach still under way drifts over both;
- a stream only wanders (:meth:`StreamSteadiness.only_wanders`) when over the long window
  each channel's drift is within its floor or within :data:`WANDER_RATIO` times its
  scatter about the drift line: stationary wander comes back, a creep towards a new level
  drifts far more than it scatters. The attitude counts as steady when it only wanders:
  the hold is then as steady as its attitude loop makes it, and the estimate's ± carries
  the rest. The set-point tolerance is judged on the mean attitude over
  :data:`RATE_WINDOW_S`, like the rates, and its lapses get the same grace as the other
  tests; an attitude that only wanders is at its set-point when its mean over the long
  window is: wander about the set-point is no departure from it (the simulated
  small-payload Heavy at 20°/20° with its ESC bands 5 µs off: its 2 s mean left the 1.5°
  tolerance for longer than the grace on 19 % of its samples, and that hold never
  settled);
- once the attitude has been steady (at its set-point, rates low, no drift or only
  wander) for :data:`EFFORT_WAIVER_S`, effort beyond its floor still counts as steady if
  it only wanders. What moves then is the disturbance the loop fights, which the
  estimate's long-run variance carries; integrators still winding up after the step (a
  creep towards a new level, the attitude already still) drift far more than they
  scatter and keep the hold unsettled.

The statistical tests have false alarms (a few % of samples each), so a failure unsettles
the hold only when it lasts longer than :data:`UNSTEADY_GRACE_S`; stale thruster data
unsettles at once. The safety envelope is not this module's business
(:class:`trimd.core.guards.Guard` checks every sample). Time is the samples' own [s].
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trimd.core.profile import ProcedureLimits
from trimd.core.samples import Attitude
from trimd.core.steady import RatioTest, last_window_drift

__all__ = ["ATTITUDE_DRIFT_SHARE", "EFFORT_WAIVER_S", "LONG_WINDOW_S", "UNSTEADY_GRACE_S",
           "WINDOW_S", "HoldSettling", "StreamSteadiness", "euler_rates"]

#: A failed steadiness test unsettles a hold only when it persists this long [s].
UNSTEADY_GRACE_S = 1.0
#: Trailing window [s] of the drift tests.
WINDOW_S = 5.0
#: The long trailing window [s] of the drift tests (module docstring).
LONG_WINDOW_S = 20.0
#: The attitude steady this long [s] makes the effort count as steady (module docstring).
EFFORT_WAIVER_S = 10.0
#: Effort whose drift over the long window is within this many times its scatter about
#: the drift line only wanders (:meth:`StreamSteadiness.only_wanders`).
WANDER_RATIO = 5.0
#: The roll and pitch rates and the attitude's distance from its set-point are judged by
#: their mean over this trailing window [s]: a vehicle turning towards its set-point keeps
#: its rate, wander about it averages out.
RATE_WINDOW_S = 2.0
#: Samples each ratio test needs before it can call a stream settled.
MIN_RATIO_SAMPLES = 12
#: The Cao–Rhinehart ratio below which a stream is steady.
R_CRIT = 2.5
#: The attitude may drift by this share of the attitude tolerance per window.
ATTITUDE_DRIFT_SHARE = 0.5


def euler_rates(a: Attitude) -> tuple[float, float]:
    """Roll and pitch rates φ̇, θ̇ [rad/s] from the body rates p, q, r (Fossen's T_Θ:
    φ̇ = p + (q·sin φ + r·cos φ)·tan θ, θ̇ = q·cos φ − r·sin φ); a yaw rate r that is not
    known (NaN) counts as none."""
    r = a.r if math.isfinite(a.r) else 0.0
    s, c = math.sin(a.phi), math.cos(a.phi)
    return a.p + (a.q * s + r * c) * math.tan(a.theta), a.q * c - r * s


class StreamSteadiness:
    """Is one stream (channels in their own units) steady, sample by sample?

    Each channel is steady when its ratio R < :data:`R_CRIT` or its significant drift
    over the trailing :data:`WINDOW_S` or :data:`LONG_WINDOW_S` is at most ``floor`` (per
    channel, the stream's units; ``inf`` ignores a channel). Not steady before the stream
    has :data:`MIN_RATIO_SAMPLES` samples spanning most of the short window; the long
    window counts once the samples span most of it.
    """

    def __init__(self, floor: ArrayLike) -> None:
        self.floor = np.asarray(floor, dtype=float)
        self._ratio = RatioTest()
        self._window = _Window()
        self.steady = False

    def update(self, t_s: float, x: ArrayLike) -> bool:
        """A new sample ``x`` at ``t_s`` [s]; is the stream steady now?"""
        v = np.atleast_1d(np.asarray(x, dtype=float))
        R = self._ratio.update(v)
        t, x = self._window.push(t_s, v, t_s - LONG_WINDOW_S)
        short = t >= t_s - WINDOW_S
        t_short = t[short]
        if self._ratio.count <= MIN_RATIO_SAMPLES or t_s - t_short[0] < 0.9 * WINDOW_S:
            self.steady = False
            return False
        if all(r < R_CRIT for r in R):  # a channel the ratio test passes needs no drift test
            self.steady = True
            return True
        ok = np.array(R) < R_CRIT
        ok |= last_window_drift(t_short, x[short], WINDOW_S) <= self.floor
        if t_s - t[0] >= 0.9 * LONG_WINDOW_S and not ok.all():
            ok |= last_window_drift(t, x, LONG_WINDOW_S) <= self.floor
        self.steady = bool(ok.all())
        return self.steady

    def window_x(self) -> NDArray[np.float64]:
        """The values (N, k) in the long window, oldest first."""
        return self._window.x

    def only_wanders(self) -> bool:
        """Does every channel move only as stationary wander does over the long window:
        its least-squares drift (slope × window) within the floor or within
        :data:`WANDER_RATIO` times the scatter about that line? A transient — a creep
        towards a new level — drifts far more than it scatters. False until the samples
        span most of the long window."""
        t, x = self._window.t.copy(), self._window.x.copy()
        if len(t) < 3 or t[-1] - t[0] < 0.9 * LONG_WINDOW_S:
            return False
        tc = t - t.mean()
        slope = (tc @ (x - x.mean(axis=0))) / (tc @ tc)
        scatter = np.std(x - x.mean(axis=0) - np.outer(tc, slope), axis=0)
        drift = np.abs(slope) * LONG_WINDOW_S
        return bool(np.all((drift <= self.floor) | (drift <= WANDER_RATIO * scatter)))


class _Window:
    """A stream's trailing samples: times ``t`` (N,) and values ``x`` (N, k), oldest
    first, in arrays that grow at the end and drop from the front (views of one buffer,
    so a sample costs no copy of the window)."""

    def __init__(self) -> None:
        self._t = np.empty(0)
        self._x = np.empty((0, 0))
        self._start = self._end = 0
        self.t, self.x = self._t, self._x

    def push(self, t_s: float, v: NDArray[np.float64], drop_before: float
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Append the sample (``t_s``, ``v``), drop those before ``drop_before`` [s] from
        the front (as long as the oldest is earlier), and return (t, x)."""
        if self._end == len(self._t):
            live = self._end - self._start
            size = max(64, 2 * live)
            t = np.empty(size)
            x = np.empty((size, len(v)))
            if live:
                t[:live] = self._t[self._start:self._end]
                x[:live] = self._x[self._start:self._end]
            self._t, self._x, self._start, self._end = t, x, 0, live
        self._t[self._end] = t_s
        self._x[self._end] = v
        self._end += 1
        while self._t[self._start] < drop_before:
            self._start += 1
        self.t, self.x = self._t[self._start:self._end], self._x[self._start:self._end]
        return self.t, self.x


class HoldSettling:
    """The settling state of one hold at set-point (``phi``, ``theta``) [rad].

    ``floor`` is the effort drift [N, N·m per row of τ] below which effort counts as
    steady (:meth:`trimd.core.decision.StopRule.effort_floor`).
    """

    def __init__(self, limits: ProcedureLimits, phi: float, theta: float,
                 floor: NDArray[np.float64]) -> None:
        self.phi, self.theta = phi, theta
        self.tol = math.radians(limits.attitude_tol_deg)
        self.rate_tol = math.radians(limits.rate_tol_deg_s)
        self._settled = GraceTimer()            # the whole hold
        self._attitude_steady = GraceTimer()    # the attitude alone (the effort waiver)
        #: the last RATE_WINDOW_S of t [s], φ̇, θ̇ [rad/s], φ, θ [rad] (one deque each: summed
        #: on every sample)
        self._recent: tuple[deque[float], ...] = tuple(deque() for _ in range(5))
        self._attitude = StreamSteadiness(np.full(2, ATTITUDE_DRIFT_SHARE * self.tol))
        self._effort = StreamSteadiness(floor)

    def effort(self, t_s: float, tau: NDArray[np.float64]) -> None:
        """A new thruster-effort sample τ [N, N·m] at ``t_s``."""
        self._effort.update(t_s, tau)

    def attitude(self, a: Attitude, have_tau: bool) -> bool:
        """A new attitude sample; is the hold settled now? ``have_tau``: fresh thruster
        outputs are held at this sample."""
        steady = self._steady(a)
        if not have_tau:                # stale thruster data: no sample of this hold
            self._settled.reset()
            return False
        self._settled.update(a.t_s, steady)
        return self._settled.on

    @property
    def steady_since(self) -> float:
        """Since when [s] the hold has been settled (NaN: it is not)."""
        return self._settled.since

    def at_setpoint(self) -> bool:
        """Is the mean roll and pitch over the last :data:`RATE_WINDOW_S` within the
        tolerance of the set-point?"""
        _, _, _, phi, theta = self._recent
        n = len(phi)
        return (n > 0 and abs(sum(phi) / n - self.phi) <= self.tol
                and abs(sum(theta) / n - self.theta) <= self.tol)

    def _wanders_about_setpoint(self) -> bool:
        """Is the mean roll and pitch over the long window (:data:`LONG_WINDOW_S`) within
        the tolerance of the set-point? For an attitude that only wanders: its 2 s mean may
        leave the tolerance for longer than the grace, as the weak loop carries it, while
        it wanders about the set-point."""
        x = self._attitude.window_x()
        return bool(np.all(np.abs(x.mean(axis=0) - (self.phi, self.theta)) <= self.tol))

    def _steady(self, a: Attitude) -> bool:
        """Is everything steady at ``a`` (before the grace of :class:`GraceTimer`)?"""
        recent = self._recent
        for d, v in zip(recent, (a.t_s, *euler_rates(a), a.phi, a.theta), strict=True):
            d.append(v)
        t, p, q = recent[:3]
        while t[0] < a.t_s - RATE_WINDOW_S:
            for d in recent:
                d.popleft()
        mean_rate = max(abs(sum(p)), abs(sum(q))) / len(t)
        still, at_setpoint = self._attitude.update(a.t_s, (a.phi, a.theta)), self.at_setpoint()
        if not (still and at_setpoint) and self._attitude.only_wanders():
            still, at_setpoint = True, at_setpoint or self._wanders_about_setpoint()
        attitude_steady = still and at_setpoint and mean_rate <= self.rate_tol
        self._attitude_steady.update(a.t_s, attitude_steady)
        return attitude_steady and (self._effort.steady or (
            a.t_s - self._attitude_steady.since >= EFFORT_WAIVER_S
            and self._effort.only_wanders()))


class GraceTimer:
    """Since when [s] a condition has held, forgiving lapses of up to
    :data:`UNSTEADY_GRACE_S` (the statistical tests' false alarms): ``since`` is NaN while
    it does not hold."""

    def __init__(self) -> None:
        self.since = self._lapse = math.nan

    @property
    def on(self) -> bool:
        return not math.isnan(self.since)

    def reset(self) -> None:
        self.since = self._lapse = math.nan

    def update(self, t_s: float, ok: bool) -> None:
        """The condition at ``t_s`` [s]."""
        if ok:
            self._lapse = math.nan
            if math.isnan(self.since):
                self.since = t_s
        elif math.isnan(self._lapse):
            self._lapse = t_s
        elif t_s - self._lapse > UNSTEADY_GRACE_S:
            self.since = math.nan
