"""The float check: let go of the vehicle and measure the attitude it floats at, its passive
trim, with no thrust map at all (docs/method.md §8). A pure state machine with the trim
procedure's interface (``step(event) -> list[Command | Notice]``, ``progress``, ``phase``,
``reason``, ``cause``, ``estimate``, ``proposal``, ``verification``), so
:class:`trimd.app.session.Session` runs and records it.

Phases: connect → precheck → confirm → settle → collect → done; ``failed`` or ``aborted``
from anywhere. On confirmation trimd commands :class:`~trimd.core.samples.OpenLoop` with
every axis at zero (ArduSub and the simulator go to MANUAL with neutral sticks: every
thruster at its neutral PWM, inside its dead band, so no thrust at all) and the vehicle
turns to its passive trim. Settle: until the means of the last two windows of
:attr:`~trimd.core.floating.FloatTiming.window_s` agree to within what the axis's
relaxation time allows (:func:`~trimd.core.floating.remaining_transient_deg`), the last
window then being collected already. Collect: until roll and pitch are known to
:data:`~trimd.core.floating.STOP_SHARE` of the level tolerance (for a float whose angles
feed a correction, ``for_correction``: only once it floats level, the one verdict that
asks for no correction), or ``collect_max_s``, or the
depth has used :data:`DEPTH_STOP_SHARE` of its envelope (a vehicle that is not neutrally
buoyant sinks or rises all the while; the result then takes at least two batches,
reaching back into the settled windows, or, still settling once two windows have been
seen, the last window, whose trend counts the transient still to come in the ±; before
that there is none; an over-damped axis is where its whole approach since letting go
ends, :func:`~trimd.core.floating.approach_end`): then the vehicle is released
and the result (:class:`~trimd.core.floating.FloatResult`) rides on the result notice, in
``verification``. Settling and collecting are timed and decided on the samples alone, so
a replay reproduces the live result exactly.

Safety is the others' (:class:`trimd.core.precheck.Precheck`,
:class:`trimd.core.guards.Guard`): no command before the operator's confirmation; while
commanding, a depth change beyond the float's envelope (the profile's
``max_depth_excursion_m`` unless the operator allows more), an attitude beyond
``max_tilt_deg`` + 5°, link loss (no telemetry for ``link_timeout_s``, or no attitude or
depth for as long as the guard allows each), someone else flying it, a disarmed vehicle,
an abort, a timeout or an internal error ends the float check with a
:class:`~trimd.core.samples.Release` first. Besides, the float check ends at once when the
vehicle floats beyond ``max_tilt_deg`` itself (it is far out of trim: a trim comes first).
"""

from __future__ import annotations

import math
from typing import Never

import numpy as np

from trimd.core.events import Cause, Notice, Output, Phase, Progress
from trimd.core.floating import (
    MIN_BATCHES,
    SETTLED_SHARE,
    FloatResult,
    Verdict,
    float_result,
    float_timing,
    known_well_enough,
    remaining_transient_deg,
)
from trimd.core.guards import Guard
from trimd.core.phases import Phases
from trimd.core.precheck import Precheck
from trimd.core.procedure import MIN_RATES_HZ
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Depth, Health, OpenLoop, Sample

__all__ = ["DEPTH_STOP_SHARE", "FLOAT_DONE", "LOOK_EVERY_S", "NEUTRAL", "FloatCheck"]

#: The open-loop input of a float: every axis at zero (thrusters at neutral PWM).
NEUTRAL = OpenLoop((0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
#: The float check stops (releasing the vehicle) once the depth has moved this share of
#: its envelope from the start, before the guard's hard limit.
DEPTH_STOP_SHARE = 0.8
#: Settling and collecting are judged every this much sample time [s].
LOOK_EVERY_S = 1.0
#: How a float check that measured the attitude ends (its last state notice says so).
FLOAT_DONE = "float check done"
#: Streams a float check needs (open loop: no thruster outputs to steer by).
_RATES = {k: v for k, v in MIN_RATES_HZ.items() if k != "thrusters"}


class FloatCheck(Phases[Never, FloatResult]):
    """A float check of the vehicle described by ``profile``.

    Parameters
    ----------
    profile : limits, timeouts, level tolerance, attitude error and the dynamics the
        settling is timed by (:func:`trimd.core.floating.float_timing`).
    confirmed : the operator confirmed up front (``--yes``).
    depth_excursion_m : the largest depth change from the start [m] (default: the
        profile's ``max_depth_excursion_m``); the float stops at
        :data:`DEPTH_STOP_SHARE` of it.
    for_correction : the angles feed a correction unless the vehicle floats level: then
        collect to ``collect_max_s`` or the depth envelope. The attitude reference's
        error wanders over tens of seconds (docs/method.md §8), so the longer mean is
        nearer the truth; the ± still carries the whole ``attitude_error_deg``, since no
        float can tell a constant part of it from the wander.
    """

    def __init__(self, profile: Profile, *, confirmed: bool = False,
                 depth_excursion_m: float | None = None, for_correction: bool = False
                 ) -> None:
        self.profile = profile
        self.for_correction = for_correction
        self._collecting_on = False    # said that it collects on for the correction
        self.proc = profile.procedure
        self.depth_excursion_m = (self.proc.max_depth_excursion_m if depth_excursion_m is None
                                  else depth_excursion_m)
        self.timing = float_timing(profile)
        self.phase = Phase.CONNECT
        self.reason = ""
        self.cause = Cause.NONE
        self.estimate = None
        self.proposal = None
        self.verification: FloatResult | None = None
        self.guard = Guard(self.proc, depth_excursion_m=self.depth_excursion_m,
                           streams=("attitude", "depth"), min_rates_hz=MIN_RATES_HZ)
        self.precheck = Precheck(_RATES, self.proc.max_depth_excursion_m)
        self._confirmed = confirmed
        self._t = self._t_data = self._t_phase = math.nan
        self._health: Health | None = None
        self._depth: Depth | None = None
        self._t_float = math.nan       # floating began [s]
        #: the depth [m] when floating began (the depth envelope's reference)
        self.start_depth_m = math.nan
        self._times: list[float] = []  # attitude samples since floating began [s]
        self._angles: list[tuple[float, float]] = []  # their roll, pitch [deg]
        self._depths: list[tuple[float, float]] = []  # (t [s], depth [m]) since then
        self._first = 0                # index of the first collected attitude sample
        self._next_look = math.nan
        #: roll/pitch may still move this much [deg] (at the last look), counts as settled
        #: below ``_steady_deg``
        self._remaining_deg = math.inf
        self._steady_deg = max(SETTLED_SHARE * profile.level_tol_deg,
                               profile.attitude_error_deg)

    # ---------------------------------------------------------------- interface
    @property
    def progress(self) -> Progress:
        settled, left = 0.0, math.inf
        elapsed = self._now_data() - self._t_phase if not math.isnan(self._t_phase) else 0.0
        if self.phase is Phase.SETTLE:
            # half for the two windows' time, half for how near they agree
            settled = 0.5 * min(1.0, elapsed / (2 * self.timing.window_s)) + 0.5 * min(
                1.0, self._steady_deg / self._remaining_deg)
            left = self.proc.settle_timeout_s - elapsed
        elif self.phase is Phase.COLLECT:
            settled, left = 1.0, self.proc.collect_max_s - elapsed
        elif self.phase is Phase.DONE:
            settled = 1.0
        samples = len(self._times) - self._first if self.phase is Phase.COLLECT else 0
        return Progress(self._t, self.phase, 0, 1, None, settled, samples, left, self.reason)

    @property
    def floating(self) -> bool:
        """trimd has let go of the vehicle and is measuring."""
        return self.phase in (Phase.SETTLE, Phase.COLLECT)

    # ---------------------------------------------------------------- events
    def _on_sample(self, s: Sample) -> list[Output[Never, FloatResult]]:
        self.precheck.sample(s)
        stop = self.guard.sample(s)
        if stop is not None and (self.phase is not Phase.CONNECT or stop.cause != Cause.LINK):
            return self._finish(Phase.FAILED, stop.reason + self._so_far(), stop.cause)
        if isinstance(s, Health):
            self._health = s
            return self._precheck()
        if isinstance(s, Depth):
            self._depth = s
            if self.floating:
                self._depths.append((s.t_s, s.depth_m))
                return self._depth_check(s)
            return []
        if isinstance(s, Attitude):
            if self.floating:
                return self._on_float(s)
            return self._precheck()
        return []

    def _ready_text(self) -> str:
        return ("ready: confirm to let go of the vehicle (thrusters at neutral) and measure "
                "how it floats")

    def _start(self) -> list[Output[Never, FloatResult]]:
        now = self._now_data()
        self._t_float = now
        self.start_depth_m = self._depth.depth_m if self._depth is not None else math.nan
        self._next_look = now + LOOK_EVERY_S
        self.guard.start(now, self.start_depth_m, "the float's start depth")
        w = self.timing
        out: list[Output[Never, FloatResult]] = [NEUTRAL]
        return out + self._enter(Phase.SETTLE, (
            f"floating: thrusters at neutral, open loop; settling (periods roll "
            f"{w.period_s[0]:.1f} s, pitch {w.period_s[1]:.1f} s; judged on two windows of "
            f"{w.window_s:.1f} s); depth envelope ±{self.depth_excursion_m:g} m"))

    # ---------------------------------------------------------------- floating
    def _on_float(self, a: Attitude) -> list[Output[Never, FloatResult]]:
        roll, pitch = math.degrees(a.phi), math.degrees(a.theta)
        self._times.append(a.t_s)
        self._angles.append((roll, pitch))
        limit = self.proc.max_tilt_deg
        if max(abs(roll), abs(pitch)) > limit:
            return self._finish(Phase.FAILED, (
                f"floats beyond the tilt limit: roll {roll:+.1f}°, pitch {pitch:+.1f}° "
                f"(max_tilt_deg {limit:g}°): far out of trim, trim it first (trimd run)"
                + self._so_far()), Cause.ENVELOPE)
        if a.t_s < self._next_look:
            return []
        self._next_look = a.t_s + LOOK_EVERY_S
        elapsed = a.t_s - self._t_phase
        if self.phase is Phase.SETTLE:
            return self._settle(elapsed)
        return self._collect(elapsed)

    def _settle(self, elapsed: float) -> list[Output[Never, FloatResult]]:
        t = np.asarray(self._times)
        rem = remaining_transient_deg(t, np.asarray(self._angles), self.timing)
        if rem is not None:
            self._remaining_deg = float(rem.max())
        if rem is None or float(rem.max()) > self._steady_deg:
            if elapsed > self.proc.settle_timeout_s:
                what = "" if rem is None else (f": roll may still move {rem[0]:.2f}°, "
                                               f"pitch {rem[1]:.2f}°")
                return self._finish(Phase.FAILED, f"timeout: the attitude did not settle in "
                                    f"{self.proc.settle_timeout_s:g} s{what}" + self._so_far(),
                                    Cause.TIMEOUT)
            return []
        self._first = int(np.searchsorted(t, t[-1] - self.timing.window_s, side="left"))
        out = self._enter(Phase.COLLECT, f"settled (roll may still move {rem[0]:.2f}°, pitch "
                          f"{rem[1]:.2f}°): collecting")
        self._t_phase = float(t[self._first])   # the last window is collected already
        return out + self._collect(self._times[-1] - self._t_phase)

    def _collect(self, elapsed: float) -> list[Output[Never, FloatResult]]:
        result = self._result("")
        known = (result.t_end_s - result.t_start_s >= MIN_BATCHES * self.timing.batch_s
                 and known_well_enough(result))
        if known and (not self.for_correction or result.verdict is Verdict.LEVEL):
            return self._done(result)
        if elapsed >= self.proc.collect_max_s:
            return self._done(self._result(f"collect_max_s ({self.proc.collect_max_s:g} s) "
                                           "reached"))
        if known and not self._collecting_on:
            self._collecting_on = True
            return [Notice(self._t, "info", f"{result.verdict.value} so far: collecting on to "
                           f"collect_max_s ({self.proc.collect_max_s:g} s) or the depth "
                           "envelope, for the correction")]
        return []

    def _reach_back(self, start_s: float) -> None:
        """Let the result begin with the last sample before ``start_s`` [s]."""
        self._first = max(0, int(np.searchsorted(self._times, start_s, side="left")) - 1)

    def _depth_check(self, d: Depth) -> list[Output[Never, FloatResult]]:
        change = d.depth_m - self.start_depth_m
        limit = DEPTH_STOP_SHARE * self.depth_excursion_m
        if not abs(change) >= limit:
            return []
        why = (f"depth {change:+.2f} m from the start ({DEPTH_STOP_SHARE:.0%} of the "
               f"±{self.depth_excursion_m:g} m envelope)")
        t, w = self._times, self.timing
        if self.phase is Phase.SETTLE and t and t[-1] - t[0] >= 2 * w.window_s:
            # judged, not yet settled: the last window (at least two batches) is the
            # result, the transient still to come counted in its ± through the trend
            self._reach_back(t[-1] - max(w.window_s, 2 * w.batch_s))
            return self._done(self._result(f"{why} before the attitude settled"))
        if self.phase is Phase.COLLECT:
            # too short for two batches: the settled windows before count too (what they
            # still hold of the transient shows in the trend, which the ± counts)
            start = t[-1] - 2 * w.batch_s
            if t[self._first] > start:
                self._reach_back(start)
            result = self._result(why)
            if result.t_end_s - result.t_start_s >= 2 * w.batch_s:
                return self._done(result)
        what = "settled" if self.phase is Phase.SETTLE else "was known"
        rate = change / max(d.t_s - self._t_float, 1e-9)
        return self._finish(Phase.FAILED, (
            f"{why} before the attitude {what}: the vehicle "
            f"{'sinks' if rate > 0 else 'rises'} at about {abs(rate):.2f} m/s "
            f"(W − B {'>' if rate > 0 else '<'} 0); bring it nearer neutral buoyancy or "
            "allow more depth change (--max-depth-excursion)" + self._so_far()),
            Cause.ENVELOPE)

    def _result(self, stopped: str) -> FloatResult:
        t = self._times[self._first:]
        depth = [(ts, d) for ts, d in self._depths if ts >= t[0]]
        change = self._depths[-1][1] - self.start_depth_m if self._depths else math.nan
        angles = np.asarray(self._angles)
        return float_result(t, angles[self._first:], depth,
                            timing=self.timing, profile=self.profile,
                            settle_s=t[0] - self._t_float, depth_change_m=change,
                            stopped=stopped, since_letting_go=(self._times, angles))

    def _done(self, result: FloatResult) -> list[Output[Never, FloatResult]]:
        self.verification = result
        out = self._finish(Phase.DONE, f"{FLOAT_DONE}: {result.verdict.value}")
        out.append(Notice(self._t, "result", result.message, verification=result))
        return out

    def _so_far(self) -> str:
        """What the float had shown when it ended early, for the reason."""
        if not self._times:
            return ""
        roll, pitch = self._angles[-1]
        change = self._depths[-1][1] - self.start_depth_m if self._depths else math.nan
        return (f" (after {self._times[-1] - self._t_float:.1f} s of floating: roll "
                f"{roll:+.2f}°, pitch {pitch:+.2f}°, depth {change:+.2f} m)")

    def _check_time(self) -> list[Output[Never, FloatResult]]:
        if self.phase.final:
            return []
        stop = self.guard.time(self._t) if self.phase is not Phase.CONNECT else None
        if stop is not None:
            return self._finish(Phase.FAILED, stop.reason + self._so_far(), stop.cause)
        if (self.phase in (Phase.CONNECT, Phase.PRECHECK)
                and self._t - self._t_phase > self.proc.connect_timeout_s):
            return self._finish(Phase.FAILED, "timeout: " + (self.reason or
                                                             "no vehicle answered"), Cause.TIMEOUT)
        return []
