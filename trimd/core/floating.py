"""The float check's physics and statistics: how long a freely floating vehicle takes to
settle in roll and pitch, when it has, and the attitude it floats at with its ± and the
verdict (docs/method.md §8).

With every thruster at neutral (inside its dead band: no thrust at all) the restoring
moment of W·r_g − B·r_b alone turns the vehicle to its passive trim, the attitude the
operator trims for; nothing here needs a thrust map. About each axis the motion is close to
a damped oscillator J·θ̈ + c·θ̇ + k·(θ − θ_trim) = 0 with J the inertia plus added
inertia [kg·m²], c the linear damping [N·m·s/rad] (the profile's, negated) and k the
stiffness at level W·z_g − B·z_b [N·m/rad], of the nominal vehicle (z_g = 0 at CG0):
−B·z_b. From them :func:`float_timing` takes each axis's natural period 2π·√(J/k) and
relaxation time (the slowest decay: 2J/c under-damped, the slow pole over-damped, one
period with no linear damping), the length of the batches the samples are averaged in
(one oscillation period, so that an oscillation averages out) and of the windows the
settling is judged on.

Angles are the attitude reference's roll and pitch [deg] (ZYX Euler, NED → body FRD); the
± is 1σ and includes the reference's own slow error (the profile's
``attitude_error_deg``), which no averaging removes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from trimd.core.jsonsafe import json_number
from trimd.core.profile import Profile

__all__ = ["MIN_BATCHES", "RELAX_REL_ERR", "SETTLED_SHARE", "STOP_SHARE", "Z95", "FloatResult",
           "FloatTiming", "Verdict", "drift_share", "float_result", "float_timing",
           "float_to_dict", "known_well_enough",
           "remaining_transient_deg"]

#: Two-sided 95 % quantile of the normal distribution.
Z95 = 1.959963984540054
#: Collecting stops once the 95 % half-width of the statistical and transient part of
#: each angle's ± is within this share of the level tolerance.
STOP_SHARE = 0.25
#: The transient still to come [deg] counts as settled below this share of the level
#: tolerance (or the attitude reference's error, whichever is larger).
SETTLED_SHARE = 0.25
#: Fewest batches of one period a result is made of (a batch-means σ needs two; a third
#: makes it less of a guess).
MIN_BATCHES = 3
#: Period [s] assumed when the profile's vehicle has no static stability to compute one.
DEFAULT_PERIOD_S = 5.0
#: Shortest batch [s]: a well-damped vehicle still averages over this much noise.
MIN_BATCH_S = 2.0
#: A relaxation time is known to this share: the profile's damping is a prior, and the
#: ballasted vehicle's stiffness is not the nominal one the time is computed with.
RELAX_REL_ERR = 0.3


class Verdict(StrEnum):
    """Does the vehicle float level within the profile's tolerance, at 95 %?"""

    LEVEL = "level"
    NOT_LEVEL = "not level"
    UNDECIDED = "undecided"


@dataclass(frozen=True, slots=True)
class FloatTiming:
    """The time scales of the floating vehicle [s], roll then pitch.

    Attributes
    ----------
    period_s : natural periods 2π·√(J/k).
    relax_s : relaxation times (the slowest decay of a transient).
    damped : the axis is over-damped (no oscillation to average out).
    """

    period_s: tuple[float, float]
    relax_s: tuple[float, float]
    damped: tuple[bool, bool]

    @property
    def batch_s(self) -> float:
        """Length of a batch [s]: the longest period of an axis that oscillates, at least
        :data:`MIN_BATCH_S`."""
        periods = [p for p, d in zip(self.period_s, self.damped, strict=True) if not d]
        return max([MIN_BATCH_S, *periods])

    @property
    def window_s(self) -> float:
        """Length of each of the two windows whose means judge the settling [s]: a batch,
        or the longest relaxation time when that is longer."""
        return max(self.batch_s, *self.relax_s)


def _axis(k: float, J: float, c: float) -> tuple[float, float, bool]:
    """Period, relaxation time [s] and over-damping of J·θ̈ + c·θ̇ + k·θ = 0."""
    if not (k > 0 and J > 0):
        return DEFAULT_PERIOD_S, DEFAULT_PERIOD_S, False
    period = 2 * math.pi * math.sqrt(J / k)
    c = max(c, 0.0)
    if c * c >= 4 * k * J:   # over-damped: the slow real pole
        return period, 2 * J / (c - math.sqrt(c * c - 4 * k * J)), True
    return period, (2 * J / c if c > 0 else period), False


def float_timing(profile: Profile) -> FloatTiming:
    """The time scales of ``profile``'s vehicle floating freely (module docstring)."""
    k = -profile.buoyancy_N * profile.r_b_m[2]
    axes = [_axis(k, profile.inertia_kg_m2[i] + profile.added_mass[3 + i],
                  -profile.linear_damping[3 + i]) for i in (0, 1)]
    return FloatTiming((axes[0][0], axes[1][0]), (axes[0][1], axes[1][1]),
                       (axes[0][2], axes[1][2]))


def _window_mean(t: np.ndarray, x: np.ndarray, start: float, end: float) -> float:
    sel = (t >= start) & (t < end)
    return float(x[sel].mean()) if sel.any() else math.nan


def remaining_transient_deg(t_s: Sequence[float] | np.ndarray, angles_deg: np.ndarray,
                            timing: FloatTiming) -> np.ndarray | None:
    """How far roll and pitch [deg] may still move: the change between the means of the
    last two windows (:attr:`FloatTiming.window_s`), as a rate, times each axis's
    relaxation time (a first-order approach θ_trim − θ = τ·θ̇). None before two windows
    of samples. ``angles_deg`` is N × 2 (roll, pitch) at times ``t_s`` [s]."""
    t = np.asarray(t_s, float)
    w = timing.window_s
    if len(t) < 4 or t[-1] - t[0] < 2 * w:
        return None
    end = t[-1] + 1e-9
    out = np.empty(2)
    for i in (0, 1):
        late = _window_mean(t, angles_deg[:, i], end - w, end)
        early = _window_mean(t, angles_deg[:, i], end - 2 * w, end - w)
        out[i] = abs(late - early) / w * timing.relax_s[i]
    return out


@dataclass(frozen=True, slots=True)
class FloatResult:
    """The attitude a vehicle floats at with its thrusters at neutral, and the verdict.

    Attributes
    ----------
    roll_deg, pitch_deg : mean roll and pitch of the collected samples [deg] (an axis of
        ``approach``: where its approach ends, :func:`approach_end`), corrected for the
        moment of the vertical drift (:func:`drift_share`).
    roll_std_deg, pitch_std_deg : their 1σ [deg]: the statistical part (batch means; an
        axis of ``approach``: their scatter about the fit), the transient (the trend times
        the relaxation time; an axis of ``approach``: what the relaxation time's own
        uncertainty makes), the moment of the vertical drift (:func:`drift_share`) and the
        attitude reference's error (``attitude_error_deg``) in quadrature.
    stat_std_deg, transient_deg, drift_deg : the statistical, transient and drift parts,
        roll and pitch [deg].
    samples : attitude samples collected.
    t_start_s, t_end_s : the collected span [s, session time].
    settle_s : from the start of floating to the first collected sample [s].
    depth_rate_m_s : the depth's rate over the collected span [m/s], positive sinking: a
        coarse sign of W − B (positive: heavier than it displaces).
    depth_change_m : depth at the end minus at the start of floating [m].
    level_tol_deg : the profile's level tolerance [deg].
    stopped : why collecting ended before its ± was reached ("" when it was).
    approach : per axis, roll and pitch: the angle is where its approach since letting go
        ends (an over-damped axis, :func:`approach_end`), not the collected mean.
    """

    roll_deg: float
    pitch_deg: float
    roll_std_deg: float
    pitch_std_deg: float
    stat_std_deg: tuple[float, float]
    transient_deg: tuple[float, float]
    drift_deg: tuple[float, float]
    samples: int
    t_start_s: float
    t_end_s: float
    settle_s: float
    depth_rate_m_s: float
    depth_change_m: float
    level_tol_deg: float
    stopped: str = ""
    approach: tuple[bool, bool] = (False, False)

    @property
    def verdict(self) -> Verdict:
        """Level: both angles within the tolerance with their 95 % interval; not level:
        one of them beyond it with its interval; else undecided."""
        pairs = ((self.roll_deg, self.roll_std_deg), (self.pitch_deg, self.pitch_std_deg))
        if all(abs(a) + Z95 * s <= self.level_tol_deg for a, s in pairs):
            return Verdict.LEVEL
        if any(abs(a) - Z95 * s > self.level_tol_deg for a, s in pairs):
            return Verdict.NOT_LEVEL
        return Verdict.UNDECIDED

    @property
    def message(self) -> str:
        """One line for the operator: the float attitude ± (95 %) and the verdict."""
        sink = "sinking" if self.depth_rate_m_s > 0 else "rising"
        text = (f"floats at roll {self.roll_deg:+.2f}° ± {Z95 * self.roll_std_deg:.2f}°, "
                f"pitch {self.pitch_deg:+.2f}° ± {Z95 * self.pitch_std_deg:.2f}° (95 %, "
                f"{self.samples} samples over {self.t_end_s - self.t_start_s:.1f} s); "
                f"{sink} at {abs(self.depth_rate_m_s):.3f} m/s: ")
        verdict = {Verdict.LEVEL: f"level within {self.level_tol_deg:g}°",
                   Verdict.NOT_LEVEL: f"NOT level within {self.level_tol_deg:g}°",
                   Verdict.UNDECIDED: f"undecided: the ± reaches past {self.level_tol_deg:g}°"
                   }[self.verdict]
        fitted = " and ".join(a for a, f in zip(("roll", "pitch"), self.approach, strict=True)
                              if f)
        return (text + verdict + (f" ({self.stopped})" if self.stopped else "")
                + (f"; {fitted}: where the approach since letting go ends" if fitted else ""))


def _batch_std(t: np.ndarray, x: np.ndarray, batch_s: float) -> tuple[float, int]:
    """σ of the mean of ``x`` by batch means (:func:`_batches`) and the number of
    batches; infinite with fewer than two."""
    means = _batches(t, x, batch_s)[1]
    if len(means) < 2:
        return math.inf, len(means)
    return float(np.std(means, ddof=1) / math.sqrt(len(means))), len(means)


def _batches(t: np.ndarray, x: np.ndarray, batch_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean time [s] and mean of ``x`` over batches of ``batch_s`` from the end back (a
    partial batch at the start left out; empty batches dropped), in time order."""
    n = int((t[-1] - t[0] + 1e-9) // batch_s)
    end = t[-1] + 1e-9
    cuts = [((t >= end - (j + 1) * batch_s) & (t < end - j * batch_s)) for j in range(n)]
    cuts = [c for c in reversed(cuts) if c.any()]
    return (np.array([t[c].mean() for c in cuts]), np.array([x[c].mean() for c in cuts]))


def _exp_fit(t: np.ndarray, x: np.ndarray, relax_s: float) -> tuple[float, float]:
    """End value and its σ of x ≈ θ_∞ + a·exp(−(t − t₀)/τ) by least squares on (t, x) (σ
    from the scatter about the fit, n − 2 degrees of freedom; infinite with fewer than 3
    points)."""
    X = np.column_stack([np.ones_like(t), np.exp(-(t - t[0]) / relax_s)])
    beta, *_ = np.linalg.lstsq(X, x, rcond=None)
    if len(t) < 3:
        return float(beta[0]), math.inf
    r = x - X @ beta
    return float(beta[0]), math.sqrt(float(np.linalg.inv(X.T @ X)[0, 0] * (r @ r)
                                            / (len(t) - 2)))


def approach_end(t_s: Sequence[float] | np.ndarray, x_deg: Sequence[float] | np.ndarray,
                 relax_s: float, batch_s: float) -> tuple[float, float, float]:
    """Where an over-damped axis's approach ends [deg]: its statistical σ and the part of
    its ± that the relaxation time's own uncertainty makes [deg].

    Let go from level, an over-damped axis moves to its trim θ_∞ along its slow pole once
    the fast one has died: θ(t) = θ_∞ + a·exp(−(t − t₀)/τ), τ the relaxation time. A mean
    of the samples lies short of θ_∞ by what the approach has still to go, always towards
    where it started; fitting the approach (least squares on the batch means of ``x_deg``
    at ``t_s`` [s], batches of ``batch_s``; the σ from their scatter about the fit) takes
    θ_∞ from the whole approach instead. τ is known to :data:`RELAX_REL_ERR`: half the
    change of θ_∞ between τ·(1 ± RELAX_REL_ERR) counts in the ±."""
    tb, xb = _batches(np.asarray(t_s, float), np.asarray(x_deg, float), batch_s)
    if len(tb) < MIN_BATCHES:
        return math.nan, math.inf, math.inf
    end, std = _exp_fit(tb, xb, relax_s)
    lo, _ = _exp_fit(tb, xb, relax_s * (1 - RELAX_REL_ERR))
    hi, _ = _exp_fit(tb, xb, relax_s * (1 + RELAX_REL_ERR))
    return end, std, abs(hi - lo) / 2


def _trend(t: np.ndarray, x: np.ndarray) -> float:
    """Least-squares slope of ``x`` over ``t`` [unit/s]."""
    dt = t - t.mean()
    den = float(dt @ dt)
    return float(dt @ (x - x.mean()) / den) if den > 0 else 0.0


def float_result(t_s: Sequence[float], angles_deg: np.ndarray, depth: Sequence[
        tuple[float, float]], *, timing: FloatTiming, profile: Profile, settle_s: float,
                 depth_change_m: float, stopped: str = "",
                 since_letting_go: tuple[Sequence[float], np.ndarray] | None = None
                 ) -> FloatResult:
    """The result of the collected attitude samples ``angles_deg`` (N × 2, roll and pitch
    [deg] at ``t_s`` [s]) and depth samples ``depth`` ((t [s], depth [m]) over the same
    span). The statistical σ is infinite with fewer than two batches.

    Each angle is the collected mean, with the collected span's trend times the
    relaxation time in its ± for the transient still to come; but an over-damped axis,
    given ``since_letting_go`` (every attitude sample since the float began, as ``t_s``
    and ``angles_deg``), is where its approach ends (:func:`approach_end`, on the samples
    from one batch after letting go: the thrusters spun down, the fast pole died; unless
    they make fewer than :data:`MIN_BATCHES` batches). The mean of a float stopped before
    the approach was over lies short of the trim, towards level, and an attitude
    reference's slow wander can hide the trend that would say so; the fit of the whole
    approach has neither fault (docs/method.md §8, "The attitude and its ±")."""
    t = np.asarray(t_s, float)
    a = np.asarray(angles_deg, float)
    d = np.asarray(depth, float).reshape(-1, 2)
    rate = _trend(d[:, 0], d[:, 1]) if len(d) >= 2 else math.nan
    share = drift_share(profile, rate)
    if since_letting_go is not None:
        t0 = np.asarray(since_letting_go[0], float)
        late = t0 >= t0[0] + timing.batch_s
        t_late, a_late = t0[late], np.asarray(since_letting_go[1], float)[late]
    mean, stat, trans, drift, std, fitted = [], [], [], [], [], []
    for i in (0, 1):
        m, s, tr = math.nan, math.inf, math.inf
        if since_letting_go is not None and timing.damped[i]:
            m, s, tr = approach_end(t_late, a_late[:, i], timing.relax_s[i], timing.batch_s)
        fitted.append(math.isfinite(s))
        if not fitted[-1]:
            m = float(a[:, i].mean())
            s, _ = _batch_std(t, a[:, i], timing.batch_s)
            tr = abs(_trend(t, a[:, i])) * timing.relax_s[i]
        mean.append(m * (1.0 + share[i]))
        dr = abs(m * share[i])
        stat.append(s)
        trans.append(tr)
        drift.append(dr)
        std.append(math.sqrt(s * s + tr * tr + dr * dr + profile.attitude_error_deg ** 2))
    return FloatResult(mean[0], mean[1], std[0], std[1],
                       (stat[0], stat[1]), (trans[0], trans[1]), (drift[0], drift[1]),
                       len(t), float(t[0]), float(t[-1]), settle_s, rate, depth_change_m,
                       profile.level_tol_deg, stopped, (fitted[0], fitted[1]))


def drift_share(profile: Profile, depth_rate_m_s: float) -> tuple[float, float]:
    """What a vertical drift does to a float angle, roll and pitch [fraction]: the trim is
    the float angle times 1 + this.

    A vehicle sinking or rising at w_d [m/s] through still water while tilted by φ moves
    along its body y and z axes at once (v = w_d·sin φ, w = w_d·cos φ), and its added
    masses turn that into a moment (Munk's; Fossen eq. 6.43, the simulator's C_A):
    −(A_w − A_v)·v·w about x, a stiffness k_m = w_d²·(A_w − A_v) [N·m/rad] beside the
    restoring k: the vehicle floats at k·φ_trim / (k + k_m), short of its trim (A_w > A_v)
    by the share k_m / k of the angle (A_u for pitch). k is the nominal vehicle's
    −B·z_b: a vehicle whose ballast is lower is stiffer and drifts less, so the share is
    a correction only to first order, and its size counts again in the ± (1σ). 0 without
    a rate, infinite without static stability."""
    if not math.isfinite(depth_rate_m_s):
        return (0.0, 0.0)
    k = -profile.buoyancy_N * profile.r_b_m[2]
    A = profile.added_mass
    munk = [depth_rate_m_s ** 2 * (A[2] - A[i]) for i in (1, 0)]
    if not k > 0:
        return tuple(math.copysign(math.inf, m) if m else 0.0  # type: ignore[return-value]
                     for m in munk)
    return (munk[0] / k, munk[1] / k)


def known_well_enough(r: FloatResult) -> bool:
    """The statistical and transient part of both angles' ± within :data:`STOP_SHARE` of
    the level tolerance at 95 %."""
    return all(Z95 * math.hypot(s, tr) <= STOP_SHARE * r.level_tol_deg
               for s, tr in zip(r.stat_std_deg, r.transient_deg, strict=True))


def float_to_dict(r: FloatResult) -> dict[str, Any]:
    """JSON-ready dict of a float check's result (units in the key names; NaN as None)."""
    return {"roll_deg": r.roll_deg, "pitch_deg": r.pitch_deg,
            "roll_std_deg": json_number(r.roll_std_deg),
            "pitch_std_deg": json_number(r.pitch_std_deg),
            "stat_std_deg": [json_number(v) for v in r.stat_std_deg],
            "transient_deg": [json_number(v) for v in r.transient_deg],
            "drift_deg": [json_number(v) for v in r.drift_deg],
            "verdict": r.verdict.value, "level": r.verdict is Verdict.LEVEL,
            "level_tol_deg": r.level_tol_deg, "samples": r.samples,
            "t_start_s": r.t_start_s, "t_end_s": r.t_end_s, "settle_s": r.settle_s,
            "depth_rate_m_s": json_number(r.depth_rate_m_s),
            "depth_change_m": json_number(r.depth_change_m), "stopped": r.stopped,
            "approach": list(r.approach),
            "message": r.message}
