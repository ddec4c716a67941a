"""The passive trim watch: steady segments of ordinary operation, their estimates, alerts.

:class:`TrimWatch` takes the samples of a link or a log in time order and never commands
anything. Every :data:`TICK_S` of sample time it runs the trim procedure's own detector
(:func:`trimd.core.holdfinder.find_segments`: attitude plateaus plus the live settling
test) over each stretch of samples that count, and turns each steady stretch into
segments of at most ``max_segment_s``. Samples count while

* the vehicle is armed (or its arming is not reported) in a mode whose class holds depth
  (:data:`DEPTH_HOLD_CLASSES`; all samples count when the source reports no mode), the
  depth is held (its rate within :data:`MAX_DEPTH_RATE_M_S`), and no pilot stick input (a
  :class:`~trimd.core.samples.PilotInput`) came: for :data:`PILOT_QUIET_S` after the
  depth moved or the sticks did, nothing counts;
* the vehicle is at rest in the water (:class:`trimd.core.motion.MotionGate`: no
  transit's surge or sway effort, no coasting after one, no DVL speed, no turn), which a
  stabilised mode's level attitude does not show.

A stretch breaks wherever a sample does not count, so each stop between transits is
settled and collected on its own (``breaks`` counts where the vehicle started moving, by
why). A segment counts when, in addition, over its span it was not turning (mean yaw
rate within the procedure's ``rate_tol_deg_s``) and not translating (a DVL's mean speed
within :data:`MAX_SPEED_M_S`; the mean surge and sway effort within the gate's force
floor of what the restoring forces alone need there).

Each segment is fitted on its own (:func:`trimd.core.segment.estimate_segment`). The
first ``baseline_segments`` level segments (or a baseline passed in, e.g. the vehicle's
last trim) form the baseline, and every later one goes through the change test
(:class:`trimd.core.change.ChangeDetector`). Post-dive and live runs feed the same class,
so they find the same segments.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Callable

import numpy as np

from trimd.core.change import Baseline, ChangeDetector, baseline_from_segments, threshold_for
from trimd.core.decision import StopRule
from trimd.core.effort import thrust_at
from trimd.core.errors import DataError, EstimationError
from trimd.core.estimate import HoldSamples, estimate_static
from trimd.core.holdfinder import find_segments
from trimd.core.model import restoring_matrix, thrust_configuration, thrusts_from_pwm
from trimd.core.motion import MAX_SPEED_M_S, MOVING_DVL, TRANSIT, MotionGate
from trimd.core.profile import Profile
from trimd.core.samples import (
    Attitude,
    Battery,
    Depth,
    Health,
    ModeClass,
    PilotInput,
    Sample,
    Thrusters,
    Velocity,
)
from trimd.core.segment import SegmentEstimate, estimate_segment, nominal_q
from trimd.core.settling import WINDOW_S
from trimd.core.watch_records import WatchAlert, WatchSegment, alert_text

__all__ = ["DEPTH_HOLD_CLASSES", "TICK_S", "TrimWatch", "WatchAlert", "WatchSegment",
           "alert_text"]

#: Mode classes in which the autopilot holds depth (in a stabilised mode the pilot's
#: throttle, not the autopilot, sets the vertical thrust).
DEPTH_HOLD_CLASSES = frozenset({ModeClass.DEPTH_HOLDING, ModeClass.AUTONOMOUS})
#: Sample time between two runs of the detector [s].
TICK_S = 10.0
#: Attitude samples this long after pilot stick input do not count [s].
PILOT_QUIET_S = 5.0
#: Depth rate [m/s] over :data:`DEPTH_WINDOW_S` [s] beyond which the depth is not held
#: (the pilot moves the depth target): nothing counts until :data:`PILOT_QUIET_S` after.
MAX_DEPTH_RATE_M_S = 0.05
DEPTH_WINDOW_S = 2.0
#: Default longest segment [s]: a long hover is cut so that a change shows within it.
MAX_SEGMENT_S = 60.0
#: Left out of the end of a plateau the pilot ended [s]: the settling test notices a
#: departure only after its grace time, and a pilot's throttle or stick starts gently.
END_MARGIN_S = WINDOW_S
#: Shortest segment [s] (a plateau's tail after its full pieces may be shorter).
MIN_SEGMENT_S = 10.0
#: The part of the AHRS's slow roll/pitch error that a segment's own long-run variance
#: does not see, so that it shows as scatter between segments [deg]: each segment's net
#: moments carry the stiffness times it (measured on the simulated Heavy with
#: ``disturb=real``: the level moments scatter between segments 1.5× their own noise σ,
#: an excess of 0.04°). Smaller than the profile's ``attitude_error_deg`` (0.1°, the whole
#: error, which a trim's short hold cannot see at all): with that, the standardised
#: moment changes of a 2 h dive without change had an RMS of 0.54–0.62 instead of ≈ 1.
SEGMENT_ATTITUDE_WANDER_DEG = 0.05
#: Default target false-alarm rate [1/h] and the segment rate it is computed for [1/h].
FALSE_ALARMS_PER_H = 0.01
SEGMENTS_PER_H = 60.0


def _t_clock(t_s: float) -> str:
    return f"t = {t_s:.0f} s"


class TrimWatch:
    """Feed samples in time order (:meth:`feed`), then :meth:`finish`; each returns the
    new records (:class:`WatchSegment`, :class:`WatchAlert`). ``rejected`` counts the
    steady stretches that did not count, by reason."""

    def __init__(self, profile: Profile, *, baseline: Baseline | None = None,
                 baseline_segments: int = 3, max_segment_s: float = MAX_SEGMENT_S,
                 false_alarms_per_h: float = FALSE_ALARMS_PER_H,
                 clock: Callable[[float], str] = _t_clock) -> None:
        self.profile = profile
        self.max_segment_s = max_segment_s
        self.h = threshold_for(false_alarms_per_h, max(SEGMENTS_PER_H, 3600 / max_segment_s))
        self.clock = clock
        self.baseline_segments = baseline_segments
        self._rule = StopRule.for_profile(profile)
        stiffness = max(self._rule.stiffness_prior_Nm, 0.0)
        wander = stiffness * math.radians(SEGMENT_ATTITUDE_WANDER_DEG)
        #: variance of each net quantity between segments that no segment sees [N², (N·m)²]
        self.floor_var = np.r_[0.0, wander**2, wander**2, wander**2]
        #: the smallest change worth an alert [N, N·m]: W − B by half what the ballast
        #: proposal may leave (half the net-buoyancy window's half-width), a moment by what
        #: would tilt the vehicle at rest by half the profile's level tolerance
        tilt = stiffness * math.radians(profile.level_tol_deg) / 2
        self.relevance = np.r_[self._rule.buoyancy_half_window_N / 2, tilt, tilt, tilt]
        self.detector = (ChangeDetector(baseline, self.h, floor_var=self.floor_var,
                                        relevance=self.relevance)
                         if baseline is not None else None)
        self.segments: list[WatchSegment] = []
        self.alerts: list[WatchAlert] = []
        self.rejected: dict[str, int] = {}
        #: what the source said about itself, for people: the vehicle (as the link names
        #: it) and notes (a link that ended)
        self.vehicle = ""
        self.notes: list[str] = []
        #: what was seen: modes (by name), attitude samples and how many counted,
        #: thruster samples
        self.modes_seen: set[str] = set()
        self.attitude_samples = self.counted_samples = self.thruster_samples = 0
        self._q_prior = baseline.q.copy() if baseline is not None else nominal_q(profile)
        if not np.all(np.isfinite(self._q_prior)):
            self._q_prior = np.where(np.isfinite(self._q_prior), self._q_prior,
                                     nominal_q(profile))
        self._T = thrust_configuration(profile.thrusters)
        #: is the vehicle at rest in the water (:mod:`trimd.core.motion`); each time it
        #: was not, the stretch broke: ``breaks`` counts them by why
        self.gate = MotionGate(profile, self._q_prior)
        self.breaks: dict[str, int] = {}
        self._motion: str | None = None
        #: runs of attitude samples that count, split where one did not (a break)
        self._runs: list[list[Attitude]] = [[]]
        self._depth: list[Depth] = []
        self._yaw_rate: list[tuple[float, float]] = []
        self._thr: list[Thrusters] = []
        self._bat: list[Battery] = []
        self._vel: list[Velocity] = []
        self._quiet_until = -math.inf
        self._state: Health | None = None
        self._seen_health = False
        self._emitted_until = -math.inf
        self._next_tick = -math.inf
        self._pending: list[SegmentEstimate] = []
        #: level segments left out of the baseline, each with why (for people)
        self.baseline_dropped: list[str] = []
        self._last_level: HoldSamples | None = None

    # ------------------------------------------------------------------ input
    def feed(self, s: Sample) -> list[WatchSegment | WatchAlert]:
        """One sample; the records it completes."""
        if isinstance(s, Health):
            self._state, self._seen_health = s, True
            self.vehicle = s.vehicle or self.vehicle
            if s.mode:
                self.modes_seen.add(s.mode)
        elif isinstance(s, PilotInput):
            self._quiet_until = s.t_s + PILOT_QUIET_S
        elif isinstance(s, Depth):
            self._depth_moving(s)
        elif isinstance(s, Thrusters):
            self._thr.append(s)
            self.thruster_samples += 1
            self._gate_effort(s)
        elif isinstance(s, Battery):
            self._bat.append(s)
        elif isinstance(s, Velocity):
            self._vel.append(s)
            self.gate.velocity(s)
        elif isinstance(s, Attitude):
            self._yaw_rate.append((s.t_s, s.r))
            self.gate.attitude(s)
            self._track_motion(s.t_s)
            self.attitude_samples += 1
            if self._counts(s):
                self._runs[-1].append(s)
                self.counted_samples += 1
            elif self._runs[-1]:
                self._runs.append([])
            if not math.isfinite(self._next_tick):
                self._next_tick = s.t_s + TICK_S
            elif s.t_s >= self._next_tick:
                self._next_tick = s.t_s + TICK_S
                return self._run(final=False)
        return []

    def finish(self) -> list[WatchSegment | WatchAlert]:
        """The records of what is still buffered (the end of a log or of a live watch)."""
        return self._run(final=True)

    def _depth_moving(self, d: Depth) -> None:
        """Track the depth rate over the last :data:`DEPTH_WINDOW_S`; while it exceeds
        :data:`MAX_DEPTH_RATE_M_S` (the pilot moves the depth target), nothing counts."""
        self._depth.append(d)
        while self._depth[0].t_s < d.t_s - DEPTH_WINDOW_S:
            self._depth.pop(0)
        first = self._depth[0]
        span = d.t_s - first.t_s
        if span >= DEPTH_WINDOW_S / 2 and abs(d.depth_m - first.depth_m) > \
                MAX_DEPTH_RATE_M_S * span:
            self._quiet_until = d.t_s + PILOT_QUIET_S

    def _gate_effort(self, s: Thrusters) -> None:
        """The sample's τ to the motion gate, at the latest battery voltage (a sample
        with the wrong number of outputs is left to the detector, which says so)."""
        if len(s.pwm_us) != len(self.profile.thrusters):
            return
        volts = self._bat[-1].voltage_V if self._bat else math.nan
        if not (math.isfinite(volts) and volts > 0):
            volts = self.profile.nominal_voltage_V
        self.gate.effort(s.t_s, thrusts_from_pwm(self.profile, s.pwm_us, volts) @ self._T.T)

    def _track_motion(self, t_s: float) -> None:
        """Ask the gate; count a break each time the vehicle starts moving."""
        why = self.gate.why_moving(t_s)
        if why is not None and why != self._motion:
            self.breaks[why] = self.breaks.get(why, 0) + 1
        self._motion = why

    def _counts(self, a: Attitude) -> bool:
        if a.t_s < self._quiet_until or self._motion is not None:
            return False
        if not self._seen_health:
            return True
        st = self._state
        return st is not None and st.mode_class in DEPTH_HOLD_CLASSES and (
            st.armed is not False)

    # ------------------------------------------------------------------ detection
    def _run(self, final: bool) -> list[WatchSegment | WatchAlert]:
        """Run the detector over each buffered run; a run that a break ended, and every
        plateau that ended, is emitted whole (less :data:`END_MARGIN_S`); the plateau that
        may go on, in full pieces only."""
        out: list[WatchSegment | WatchAlert] = []
        open_start = None
        if self._thr:
            t = np.array([s.t_s for s in self._thr])
            thrust, ok, held = thrust_at(self.profile, t, self._thr, self._bat)
            thrust, held = thrust[ok], held.take(ok)
            tau = thrust @ self._T.T
            for k, run in enumerate(self._runs):
                last = k == len(self._runs) - 1
                if len(run) < 2:
                    continue
                for hold, ended in find_segments(run, t[ok], tau, self.profile, thrust, held):
                    closed = ended or not last
                    if closed:  # the pilot ended it: leave out what the test saw late
                        hold = hold.take(hold.t_s <= hold.t_s[-1] - END_MARGIN_S)
                    for chunk in self._chunks(hold, complete_only=not (closed or final)):
                        out.extend(self._segment(chunk))
                    if not closed:
                        open_start = float(hold.t_s[0])
        self._cut(open_start)
        return out

    def _chunks(self, hold: HoldSamples, complete_only: bool) -> list[HoldSamples]:
        """The hold's samples after what was already emitted, in pieces of at most
        ``max_segment_s`` (equal pieces); while the plateau may go on, only full pieces of
        ``max_segment_s``. Pieces shorter than :data:`MIN_SEGMENT_S` are left out."""
        idx = np.flatnonzero(hold.t_s > self._emitted_until)
        if len(idx) < 2:
            return []
        t = hold.t_s[idx]
        span = float(t[-1] - t[0])
        if complete_only:
            n = math.floor(span / self.max_segment_s)
            edges = t[0] + self.max_segment_s * np.arange(n + 1)
        else:
            n = max(1, math.ceil(span / self.max_segment_s - 1e-9))
            edges = t[0] + span * np.arange(n + 1) / n
            edges[-1] = np.nextafter(t[-1], math.inf)
        chunks = []
        for k in range(n):
            sel = idx[(t >= edges[k]) & (t < edges[k + 1])]
            if len(sel) < 2:
                continue
            self._emitted_until = float(hold.t_s[sel[-1]])
            if hold.t_s[sel[-1]] - hold.t_s[sel[0]] < MIN_SEGMENT_S:
                self.rejected["too short"] = self.rejected.get("too short", 0) + 1
                continue
            chunks.append(hold.take(sel, ""))
        return chunks

    def _cut(self, open_start: float | None) -> None:
        """Drop buffered samples the detector will not need again: every run a break
        ended, and of the last run all but the stretch that may still become a plateau,
        or the open plateau (re-settled before what is not yet emitted once it is longer
        than a segment: each tick re-runs the settling test over what is kept, so a long
        hover kept whole cost a 60 s segment's samples up to 30 runs each; the segments
        came out the same, bit for bit, on three simulated dives)."""
        run = self._runs[-1]
        self._runs = [run]
        if not run:
            return
        lead = 2 * self.profile.procedure.min_steady_s + 2 * WINDOW_S
        t_last = run[-1].t_s
        if open_start is None:
            cut = t_last - lead
        elif t_last - open_start > self.max_segment_s:
            cut = self._emitted_until - lead
        else:
            cut = open_start - lead
        self._runs = [[a for a in run if a.t_s >= cut]]
        keep_from = cut - 1.0
        self._thr = [s for s in self._thr if s.t_s >= keep_from]
        # the voltage is held: keep the last battery sample before the cut too
        self._bat = ([b for b in self._bat if b.t_s < keep_from][-1:]
                     + [b for b in self._bat if b.t_s >= keep_from])
        self._vel = [v for v in self._vel if v.t_s >= keep_from]
        self._yaw_rate = [r for r in self._yaw_rate if r[0] >= keep_from]

    def _moving(self, hold: HoldSamples) -> str | None:
        """Why the stretch is not a steady segment of a vehicle at rest (None: it is)."""
        proc = self.profile.procedure
        t0, t1 = hold.t_s[0], hold.t_s[-1]
        r = [r for t, r in self._yaw_rate if t0 <= t <= t1]
        if r and abs(float(np.mean(r))) > math.radians(proc.rate_tol_deg_s):
            return "turning"
        v = [(s.u, s.v) for s in self._vel if t0 <= s.t_s <= t1]
        if v and float(np.hypot(*np.mean(v, axis=0))) > MAX_SPEED_M_S:
            return MOVING_DVL
        phi, theta = float(np.mean(hold.phi)), float(np.mean(hold.theta))
        expected = restoring_matrix(phi, theta) @ self._q_prior
        excess = np.abs(hold.tau.mean(axis=0) - expected)
        if max(excess[0], excess[1]) > self.gate.force_floor:
            return TRANSIT
        return None

    def _segment(self, hold: HoldSamples) -> list[WatchSegment | WatchAlert]:
        why = self._moving(hold)
        if why is not None:
            self.rejected[why] = self.rejected.get(why, 0) + 1
            return []
        index = len(self.segments) + 1
        named = dataclasses.replace(hold, label=f"segment {index}")
        try:
            est = estimate_segment(named, self.profile, self._q_prior)
        except (EstimationError, DataError) as exc:
            key = f"not estimable ({exc})"
            self.rejected[key] = self.rejected.get(key, 0) + 1
            return []
        level = all(est.observable[:3])
        full = None
        if level:
            self._last_level = named
        elif self._last_level is not None:
            # a tilted segment with the last level one: two attitudes determine all four
            with contextlib.suppress(EstimationError):
                full = estimate_static([self._last_level, named], self.profile)
        baseline = self.detector is None and level
        seg = WatchSegment(index, est, baseline=baseline, full=full)
        self.segments.append(seg)
        out: list[WatchSegment | WatchAlert] = [seg]
        if baseline:
            self._offer_to_baseline(est)
        elif self.detector is not None:
            for a in self.detector.update(est):
                alert = WatchAlert(a, alert_text(a, self.clock))
                self.alerts.append(alert)
                out.append(alert)
        return out

    def _offer_to_baseline(self, est: SegmentEstimate) -> None:
        """Form the baseline once the last ``baseline_segments`` level segments agree
        (:func:`baseline_from_segments`); while they do not (the trim moving as they were
        measured), the oldest is dropped and why kept in ``baseline_dropped``. After as
        many drops as the baseline has segments it forms from the last ones, its ± widened
        to their scatter."""
        self._pending.append(est)
        if len(self._pending) < self.baseline_segments:
            return
        source = (f"{self._pending[0].label} to {self._pending[-1].label}"
                  if self.baseline_dropped else None)
        widen = len(self.baseline_dropped) >= self.baseline_segments  # no longer wait
        try:
            baseline = baseline_from_segments(self._pending, self.floor_var, source, widen)
        except EstimationError as exc:
            self.baseline_dropped.append(f"{self._pending.pop(0).label}: {exc}")
            return
        self.detector = ChangeDetector(baseline, self.h, floor_var=self.floor_var,
                                       relevance=self.relevance)
