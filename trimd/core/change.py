"""Has the trim changed? A two-sided CUSUM on the segments' standardised innovations.

Each steady segment (:mod:`trimd.core.segment`) gives the net quantities it observes,
q_i (i: W − B, W·x_g − B·x_b, W·y_g − B·y_b). Against a baseline b_i its innovation
δ_i = q_i − b_i has the variance

    σ_i² = σ_noise,i² + σ_floor,i² (the segment's) + σ_b,i² (the baseline's)
           + ‖G_i − G_b,i‖²,

σ_floor the wander between segments that no segment sees in its own samples (slow AHRS
error: ``floor_var``), G the sensitivity to the thrust curves' gain errors: the same
thrusters fly every segment, so only the difference of the exposures enters (a baseline without its
exposure, e.g. a trim's estimate, contributes its full covariance and the segment its
own gain share, which is conservative). The test on z = δ/σ, per component, is Page's
two-sided CUSUM:

    S⁺ ← max(0, S⁺ + z − k),  S⁻ ← max(0, S⁻ − z − k),  alert when S⁺ or S⁻ > h,

with k = :data:`CUSUM_K` (tuned to a shift of 2k = 1σ) and h chosen for a false-alarm
rate: by Siegmund's approximation one one-sided CUSUM on unit-normal z runs on average
ARL₀ = (e^{2k·b} − 2k·b − 1)/(2k²), b = h + 1.166, segments between false alarms; the
watch runs 2 sides × 3 components, so its rate per segment is 6/ARL₀ and per hour that
times the segments per hour (:func:`threshold_for`). The change began at the first
segment since the statistic last stood at 0 that is :data:`Z_START` σ off on its own in
the alert's direction (the CUSUM's own restart point precedes a step by a few segments
of noise; a most-likely step split would date a ramp, a leak, too late); the change is
the weighted mean innovation of the segments from there on, with its ± (the segments'
own variances, plus the baseline's once). A change smaller than what matters
(``relevance``: the watch uses, for the moments, what would tilt the vehicle at rest by
half the profile's ``level_tol_deg``) restarts the test without an alert. After an
alert the component is tested against the alerting segment's level, from 0 again (a leak
that goes on alerts again as it grows); the total change stays against the baseline.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.special import chdtrc  # scipy.stats' chi2.sf, without its 0.4 s import

from trimd.core.errors import EstimationError
from trimd.core.estimate import StaticEstimate
from trimd.core.segment import Q_NAMES, SegmentEstimate
from trimd.core.types import FloatArray

__all__ = ["COMPONENTS", "CUSUM_K", "DISAGREE_P", "Baseline", "ChangeAlert", "ChangeDetector",
           "baseline_from_estimate", "baseline_from_segments", "threshold_for"]

#: CUSUM reference value k [σ]: half the shift it is tuned to.
CUSUM_K = 0.5
#: A segment this many σ off on its own marks where a change began.
Z_START = 2.0
#: The components tested (index into q): W − B and the two moments that level segments
#: observe. W·z_g − B·z_b is never observable at level.
COMPONENTS = (0, 1, 2)
#: Segments offered as a baseline disagree when, for one component, their scatter about
#: the weighted mean has a χ² tail probability below this: far out, as between-segment
#: wander that the segments' own ± understates (strong disturbance torques at 20 s
#: correlation: χ² 14–27 on 2 degrees of freedom in simulated dives) is not a change,
#: while a step of 2 N gives χ² 43.
DISAGREE_P = 1e-6


def threshold_for(false_alarms_per_h: float, segments_per_h: float, k: float = CUSUM_K,
                  tests: int = 2 * len(COMPONENTS)) -> float:
    """The CUSUM threshold h [σ] for ``false_alarms_per_h`` at ``segments_per_h``, by
    Siegmund's approximation over ``tests`` one-sided CUSUMs (module docstring).

    Examples
    --------
    >>> round(threshold_for(0.01, 60), 2)
    8.63
    """
    arl = tests * segments_per_h / false_alarms_per_h
    lo, hi = 0.0, 200.0
    for _ in range(100):
        h = (lo + hi) / 2
        b = 2 * k * (h + 1.166)
        if (math.exp(b) - b - 1) / (2 * k * k) < arl:
            lo = h
        else:
            hi = h
    return (lo + hi) / 2


@dataclass(frozen=True, eq=False)
class Baseline:
    """What the trim is compared with: q [N, N·m], the variance of each component, and
    (when known) its gain sensitivity (4, 4·n) (:attr:`SegmentEstimate.gain_sensitivity`);
    ``source`` says where it came from, for people."""

    q: FloatArray
    var: FloatArray
    gain_sensitivity: FloatArray | None
    source: str


def baseline_from_segments(segments: Sequence[SegmentEstimate],
                           floor_var: FloatArray | None = None,
                           source: str | None = None, widen: bool = False) -> Baseline:
    """Per component, the inverse-variance weighted mean of the segments that observe it
    (their noise variances plus ``floor_var``, the wander between segments; the shared
    gain exposure averaged with the same weights), named ``source`` for people (by
    default "the first n segments").

    When the segments disagree (a component's χ² about the mean, :func:`_scatter`, has a
    tail probability below :data:`DISAGREE_P`) the trim moved between them (a piece lost,
    a float torn off) and their mean would be a level the vehicle never had:
    EstimationError saying which and by how much; with ``widen``, the baseline instead,
    each disagreeing component's variance at least the segments' own weighted scatter
    about it (which of those levels the vehicle holds now is not known), and the source
    saying so. A slow leak widens each segment's own ± instead and is not caught so."""
    floor = np.zeros(4) if floor_var is None else np.asarray(floor_var, float)
    q, var = np.full(4, np.nan), np.full(4, np.inf)
    gain = np.zeros((4, segments[0].gain_sensitivity.shape[1]))
    widened = []
    for i in range(4):
        use = [s for s in segments if s.observable[i]]
        if not use:
            continue
        v = np.array([max(s.q_cov_noise[i, i] + floor[i], 1e-18) for s in use])
        w = (1 / v) / np.sum(1 / v)
        q[i] = sum(wk * s.q[i] for wk, s in zip(w, use, strict=True))
        var[i] = float(np.sum(w**2 * v))
        gain[i] = sum(wk * s.gain_sensitivity[i] for wk, s in zip(w, use, strict=True))
        if i not in COMPONENTS or len(use) < 2:
            continue
        chi2 = _scatter(use, v, w, i)
        if chdtrc(len(use) - 1, chi2) >= DISAGREE_P:
            continue
        spread = np.array([s.q[i] for s in use])
        why = (f"{Q_NAMES[i]} ranged {spread.min():+.3f} to {spread.max():+.3f} "
               f"{'N' if i == 0 else 'N·m'} over {len(use)} segments (χ² {chi2:.0f} "
               f"on {len(use) - 1} degrees of freedom)")
        if not widen:
            raise EstimationError(why)
        var[i] = max(var[i], float(w @ (spread - q[i]) ** 2) * len(use) / (len(use) - 1))
        widened.append(why)
    source = source or f"the first {len(segments)} segments"
    if widened:
        source += f" (they disagreed, their ± widened to their scatter: {'; '.join(widened)})"
    return Baseline(q, var, gain, source)


def _scatter(use: Sequence[SegmentEstimate], v: FloatArray, w: FloatArray, i: int) -> float:
    """χ² = Σ (q_k − q̄)²/σ_k² of component ``i`` of the segments ``use`` about their
    weighted mean (weights ``w``), σ_k² a segment's noise-and-floor variance ``v`` plus its
    gain exposure's difference from the mean exposure, as the change test counts them."""
    q = np.array([s.q[i] for s in use])
    g = np.array([s.gain_sensitivity[i] for s in use])
    return float(np.sum((q - w @ q) ** 2 / (v + np.sum((g - w @ g) ** 2, axis=1))))


def baseline_from_estimate(est: StaticEstimate, source: str) -> Baseline:
    """A trim's estimate (e.g. the vehicle's last trim, from its history) as the baseline:
    its q and the variances of its full ± (its gain exposure is not kept, so the test
    counts each segment's own gain share in full: conservative)."""
    return Baseline(est.q.copy(), np.diag(est.q_cov).copy(), None, source)


@dataclass(frozen=True)
class ChangeAlert:
    """A significant change of one net quantity (SI units, 1σ).

    Attributes
    ----------
    component : index into q (0 W − B [N], 1 W·x_g − B·x_b, 2 W·y_g − B·y_b [N·m]).
    total, total_std : the alerting segment's value minus the baseline's: the change
        since the baseline, now.
    change, change_std : the mean change of the segments since the change, against the
        level before it (the baseline, or the level at this component's last alert).
    after_s, since_s : the change came after the end of the last unchanged segment
        (``after_s``, NaN when there was none) and by the start of the first changed one
        (``since_s``) [s].
    at_s : end of the segment that raised the alert [s].
    segments : how many segments the change estimate averages.
    statistic : the CUSUM statistic [σ] that crossed the threshold.
    first : the first alert of this component (the level before it was the baseline).
    """

    component: int
    total: float
    total_std: float
    change: float
    change_std: float
    after_s: float
    since_s: float
    at_s: float
    segments: int
    statistic: float
    first: bool


@dataclass
class _Reference:
    """The level a component is tested against: q_i, its variance, its gain row (None:
    unknown, the segment's own gain share counts in full)."""

    q: float
    var: float
    gain: FloatArray | None


@dataclass
class _Cusum:
    up: float = 0.0
    down: float = 0.0
    #: end of the last segment at which the statistic stood at 0, per side
    zero_up: float = math.nan
    zero_down: float = math.nan
    #: since then, per side: (δ, own variance, segment start, end) — its own variance
    #: excludes the reference's, which every δ shares
    run_up: list[tuple[float, float, float, float]] = field(default_factory=list)
    run_down: list[tuple[float, float, float, float]] = field(default_factory=list)


def _step(run: list[tuple[float, float, float, float]], sign: float, ref_var: float
          ) -> tuple[int, float, float]:
    """Where in ``run`` the change began — the first segment that by itself is
    :data:`Z_START` σ off in the alert's direction ``sign`` (±1), else the first — the
    mean change from there on, and its variance (the segments' own)."""
    d = np.array([r[0] for r in run])
    v = np.array([r[1] for r in run])
    off = np.flatnonzero(sign * d / np.sqrt(v + ref_var) >= Z_START)
    j = int(off[0]) if len(off) else 0
    w = 1 / v[j:]
    return j, float(np.sum(w * d[j:]) / w.sum()), float(1 / w.sum())


def _innovation(seg: SegmentEstimate, i: int, ref: _Reference, floor_var: float
                ) -> tuple[float, float]:
    """δ = q_i − reference and the segment's own variance of it (its noise, the wander
    between segments ``floor_var``, gain exposures by their difference when the
    reference's is known)."""
    g = seg.gain_sensitivity[i] - ref.gain if ref.gain is not None else \
        seg.gain_sensitivity[i]
    return float(seg.q[i] - ref.q), float(seg.q_cov_noise[i, i] + floor_var + g @ g)


class ChangeDetector:
    """Feed :class:`SegmentEstimate` values in time order; get the alerts they raise.
    ``floor_var`` (4,) is the wander between segments no segment sees [N², (N·m)²];
    ``relevance`` (4,) the smallest change worth an alert [N, N·m]: a crossing of the
    threshold by a smaller change (since the baseline, now; after an alert, the step
    since it) restarts the test without an alert.
    After an alert the component is tested against the alerting segment's level (a
    change that goes on, a leak, alerts again as it grows); ``total`` stays against the
    baseline."""

    def __init__(self, baseline: Baseline, h: float, k: float = CUSUM_K,
                 floor_var: FloatArray | None = None,
                 relevance: FloatArray | None = None) -> None:
        self.baseline, self.h, self.k = baseline, h, k
        self.floor_var = np.zeros(4) if floor_var is None else np.asarray(floor_var, float)
        self.relevance = np.zeros(4) if relevance is None else np.asarray(relevance, float)
        #: crossings of the threshold whose change was below ``relevance`` (no alert)
        self.suppressed = 0
        b = baseline
        self._base = {i: _Reference(float(b.q[i]), float(b.var[i]), None if
                                    b.gain_sensitivity is None else b.gain_sensitivity[i])
                      for i in COMPONENTS}
        self._ref = dict(self._base)
        self._cusum = {i: _Cusum() for i in COMPONENTS}
        self._alerted: set[int] = set()

    def update(self, seg: SegmentEstimate) -> list[ChangeAlert]:
        """Run the test on one segment; the alerts it raises (at most one per component)."""
        alerts = []
        for i, c in self._cusum.items():
            ref = self._ref[i]
            if not seg.observable[i] or not math.isfinite(ref.q):
                continue
            delta, own = _innovation(seg, i, ref, float(self.floor_var[i]))
            z = delta / math.sqrt(own + ref.var)
            c.up, c.down = max(0.0, c.up + z - self.k), max(0.0, c.down - z - self.k)
            for side, value in (("up", c.up), ("down", c.down)):
                run = getattr(c, f"run_{side}")
                if value == 0.0:
                    run.clear()
                    setattr(c, f"zero_{side}", seg.t_end_s)
                else:
                    run.append((delta, own, seg.t_start_s, seg.t_end_s))
            if max(c.up, c.down) <= self.h:
                continue
            up = c.up > c.down
            run = c.run_up if up else c.run_down
            j, change, change_var = _step(run, 1.0 if up else -1.0, ref.var)
            after = (c.zero_up if up else c.zero_down) if j == 0 else run[j - 1][3]
            total, own_total = _innovation(seg, i, self._base[i], float(self.floor_var[i]))
            # significant, but too small to matter: the change since the baseline for a
            # first alert, the step since the last alert for a later one
            if abs(total if i not in self._alerted else change) < self.relevance[i]:
                self.suppressed += 1
                self._cusum[i] = _Cusum(zero_up=seg.t_end_s, zero_down=seg.t_end_s)
                continue
            alerts.append(ChangeAlert(
                i, total, math.sqrt(own_total + self._base[i].var), change,
                math.sqrt(change_var + ref.var), after, run[j][2], seg.t_end_s,
                len(run) - j, max(c.up, c.down), i not in self._alerted))
            self._alerted.add(i)
            self._ref[i] = _Reference(float(seg.q[i]),
                                      float(seg.q_cov_noise[i, i] + self.floor_var[i]),
                                      seg.gain_sensitivity[i].copy())
            self._cusum[i] = _Cusum(zero_up=seg.t_end_s, zero_down=seg.t_end_s)
        return alerts
