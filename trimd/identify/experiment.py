"""The open-loop excitation experiment: a pure state machine with the trim procedure's
interface (``step(event) -> list[Command | Notice]``, ``progress``, ``phase``, ``reason``,
``cause``, ``estimate``, ``proposal``, ``verification``), so
:class:`trimd.app.session.Session` runs it.

Phases: connect → precheck → confirm → excite (the :class:`~trimd.identify.signals.Signal`
as :class:`~trimd.core.samples.OpenLoop` commands, one per change; with an attitude hold in
the signal, its PID output on the latest attitude is added on roll and pitch, and the
depth hold's on heave) → done; ``failed`` or ``aborted`` from anywhere. The experiment
keeps its envelope (:class:`~trimd.identify.envelope.Envelope`): as the vehicle goes
further than the design meant, the excitation is scaled down, and near the guard's limits
it stops early — done, saying so (:data:`~trimd.identify.envelope.STOP_EARLY`), with every
sample up to the stop recorded. Notices record what it did: the holds and their
bandwidths at the start, each scaling, and at the end the depth and tilt it reached.
The precheck and the safety rules are the procedure's own
(:class:`trimd.core.precheck.Precheck`: armed, not in a mode where the vehicle follows its
own plan or failsafe, attitude and depth at their rates, depth steady;
:class:`trimd.core.guards.Guard`): no command before the operator's confirmation; while
commanding, an attitude beyond ``max_tilt_deg`` + 5°, a depth excursion beyond the
experiment's limit from the start depth, link loss (a Health sample that is not
connected, no telemetry for ``link_timeout_s``, or no attitude or depth for as long as
the guard allows each), someone else flying it or a disarmed vehicle ends the
experiment; so do a timeout and an internal error — every end after the first command
sends :class:`~trimd.core.samples.Release`. Time is the samples' own.

Commands change only when a thruster sample arrives (at attitude samples while the vehicle
reports no thruster outputs, or reports them less often than every
:data:`MAX_PACED_INTERVAL_S`, too slow for the attitude hold's loop): the fit knows the
thrust only from that record, and a
command that acted between two of its samples (an attitude hold updated at 20 Hz beside
thruster outputs at 10 Hz, the simulator's default) would be an input nobody recorded —
with it, the BlueROV2 Heavy's rotational inertia sums came out 10–37 % off
(docs/identification.md). The next thruster sample shows each command.
"""

from __future__ import annotations

import math
from typing import Never

from trimd.core.events import Cause, Notice, Output, Phase, Progress
from trimd.core.guards import ENVELOPE_MARGIN_DEG, Guard
from trimd.core.phases import Phases
from trimd.core.precheck import Precheck
from trimd.core.procedure import MIN_RATES_HZ
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Depth, Health, OpenLoop, Sample, Thrusters
from trimd.identify.envelope import STOP_EARLY, Envelope, Step
from trimd.identify.model import STAGES
from trimd.identify.signals import HoldAxis, Signal

__all__ = ["MAX_PACED_INTERVAL_S", "STAGE_NOTICE", "STREAM_HZ", "Excite", "stage_of_notice"]

#: The words before the stage's name in the notice that starts an excitation.
STAGE_NOTICE = "stage "


def stage_of_notice(text: str) -> str | None:
    """The stage an excitation notice names ("exciting stage uwq: open-loop inputs on
    axes X, Z, M"), or, for a notice of an older recording without it, the stage whose
    axes it lists; None for any other text."""
    head, sep, rest = text.partition(": open-loop inputs on axes ")
    if not sep or not head.startswith("exciting"):
        return None
    named = head.removeprefix("exciting").strip()
    if named.startswith(STAGE_NOTICE):
        name = named.removeprefix(STAGE_NOTICE)
        return name if name in STAGES else None
    axes = tuple(sorted("XYZKMN".index(a.strip()) for a in rest.split(",")
                        if a.strip() in tuple("XYZKMN")))
    return next((n for n, st in STAGES.items() if st.axes == axes), None)


#: Longest interval [s] between thruster samples at which commands are paced by them (the
#: attitude hold's loop, up to 4 rad/s, needs updates at 10 Hz or faster).
MAX_PACED_INTERVAL_S = 0.11

#: Rate [Hz] of attitude, thruster outputs and depth that ``trimd excite`` asks the vehicle
#: for (a ``rate=`` in a MAVLink URL, attitude_hz … in a ``sim:`` one, say otherwise): the
#: fit knows when a command acted only to within the thruster record's interval, and a
#: DOF faster than that interval (the Sabertooth's pitch, about 0.07 s) has its inertia
#: determined only through that timing (docs/identification.md, "Fast DOFs at slow
#: streams").
STREAM_HZ = 50.0
#: What each held axis is called in the notices.
_HELD = {2: "depth", 3: "roll", 4: "pitch"}


class Excite(Phases[Never, Never]):
    """An excitation experiment of ``signal`` on the vehicle of ``profile``.

    Parameters
    ----------
    profile : tilt limit, link and connect timeouts.
    signal : the inputs to play (:func:`trimd.identify.signals.design_signal`).
    confirmed : the operator confirmed up front (``--yes``).
    depth_excursion_m : the largest allowed depth change from the start [m].
    stage : the identification stage the signal excites (uvr, uwq, uvwpqr), named in the
        notice that starts the excitation ("exciting stage uvr: …") so that a recording
        says which stage it holds (:data:`STAGE_NOTICE`).
    """

    def __init__(self, profile: Profile, signal: Signal, *, confirmed: bool = False,
                 depth_excursion_m: float = 5.0, stage: str | None = None) -> None:
        self.profile = profile
        self.signal = signal
        self.stage = stage
        self.phase = Phase.CONNECT
        self.reason = ""
        self.cause = Cause.NONE
        self.estimate = None
        self.proposal = None
        self.verification = None
        # open loop drives thrusters, so no thruster stream is needed to steer by
        self.guard = Guard(profile.procedure, depth_excursion_m=depth_excursion_m,
                           streams=("attitude", "depth"), min_rates_hz=MIN_RATES_HZ)
        # open loop: the thruster outputs are not steered by, so not required
        self.precheck = Precheck({k: v for k, v in MIN_RATES_HZ.items() if k != "thrusters"},
                                 profile.procedure.max_depth_excursion_m)
        self._confirmed = confirmed
        self._t = self._t_data = self._t_phase = math.nan
        self._t_start = math.nan
        self._health: Health | None = None
        self._depth: float = math.nan
        self._depth_ref = math.nan
        self._attitude: Attitude | None = None   # the latest
        self._paced = False   # commands change at thruster samples (module docstring)
        self._t_thrusters = math.nan
        self._last: tuple[float, ...] | None = None
        self._integral = {h.axis: 0.0 for h in signal.hold}
        self._t_hold = math.nan
        self._depth_integral = 0.0
        self._t_depth = math.nan
        self._heave = 0.0  # the depth hold's output [input], added to the heave offset
        #: how far the vehicle has gone, and how far the excitation is scaled down for it
        self.envelope = Envelope(depth_excursion_m, math.radians(
            profile.procedure.max_tilt_deg + ENVELOPE_MARGIN_DEG))

    # ---------------------------------------------------------------- interface
    @property
    def progress(self) -> Progress:
        done = 0.0
        left = math.inf
        if self.phase is Phase.COLLECT and not math.isnan(self._t):
            done = min(1.0, (self._t - self._t_start) / self.signal.duration_s)
            left = self.signal.duration_s - (self._t - self._t_start)
        elif self.phase is Phase.DONE:
            done = 1.0
        return Progress(self._t, self.phase, 0, 1, None, done, 0, left, self.reason)

    # ---------------------------------------------------------------- events
    def _on_sample(self, s: Sample) -> list[Output[Never, Never]]:
        self.precheck.sample(s)
        stop = self.guard.sample(s)
        if stop is not None and (self.phase is not Phase.CONNECT or stop.cause != Cause.LINK):
            return self._finish(Phase.FAILED, stop.reason, stop.cause)
        if isinstance(s, Health):
            self._health = s
            return self._precheck()
        if isinstance(s, Depth):
            self._depth = s.depth_m
            if self.phase is not Phase.COLLECT:
                return []
            if self.signal.depth_hold is not None:
                self._hold_depth(s, self.signal.depth_hold)
            return self._keep(self.envelope.depth(s.depth_m - self._depth_ref))
        if isinstance(s, Attitude):
            self._attitude = s
            if self.phase is Phase.COLLECT:
                kept = self._keep(self.envelope.tilt(s.phi, s.theta))
                return kept if kept or self._paced else self._play(s)
            return self._precheck()
        if isinstance(s, Thrusters):
            self._paced = s.t_s - self._t_thrusters <= MAX_PACED_INTERVAL_S
            self._t_thrusters = s.t_s
            if self.phase is Phase.COLLECT and self._paced:
                return self._play(self._attitude)
        return []

    def _ready_text(self) -> str:
        return (f"ready: confirm to let trimd drive the vehicle open loop for "
                f"{self.signal.duration_s:g} s")

    def _start(self) -> list[Output[Never, Never]]:
        self._depth_ref = self._depth
        self._t_start = self._now_data()
        self.guard.start(self._now_data(), self._depth, "the start depth")
        named = f" {STAGE_NOTICE}{self.stage}" if self.stage else ""
        out = self._enter(Phase.COLLECT, f"exciting{named}: open-loop inputs on axes "
                          + ", ".join("XYZKMN"[d.axis] for d in self.signal.axes))
        holds = [h for h in (*self.signal.hold, self.signal.depth_hold) if h is not None]
        if holds:
            out.append(Notice(self._t, "info", "holding " + ", ".join(
                f"{_HELD[h.axis]} at {h.bandwidth_rad_s:.2f} rad/s" for h in holds)
                + " (their output is in the recorded thrust)"))
        return out + self._play(None)

    def _keep(self, step: Step | None) -> list[Output[Never, Never]]:
        """Act on what the envelope asks for: a notice of the scaled excitation, or the
        early stop (done, every sample up to here recorded)."""
        if step is None:
            return []
        elapsed = self._now_data() - self._t_start
        if step.stop:
            return self._finish(Phase.DONE, f"{STOP_EARLY} at {elapsed:.1f} s of "
                                f"{self.signal.duration_s:g} s: {step.text}; the data up to "
                                f"here is kept ({self.envelope.summary()})")
        return [Notice(self._t, "warning", f"at {elapsed:.1f} s: {step.text}")]

    def _play(self, attitude: Attitude | None) -> list[Output[Never, Never]]:
        """The inputs at the present time: the signal, plus the attitude hold's output on
        the held axes when ``attitude`` is a new measurement."""
        elapsed = self._now_data() - self._t_start
        if elapsed >= self.signal.duration_s:
            return self._finish(Phase.DONE, f"excitation complete ({elapsed:.1f} s): "
                                + self.envelope.summary())
        axes = self.signal.at(elapsed)
        scale = self.envelope.scale
        if scale < 1:
            a = [o + scale * (x - o) for x, o in zip(axes, self.signal.offsets, strict=True)]
            axes = (a[0], a[1], a[2], a[3], a[4], a[5])
        if self._heave:
            axes = (axes[0], axes[1], max(-1.0, min(1.0, axes[2] + self._heave)), *axes[3:])
        if attitude is not None and self.signal.hold:
            axes = self._hold(axes, attitude)
        if axes == self._last:
            return []
        self._last = axes
        return [OpenLoop(axes)]

    def _hold(self, axes: tuple[float, ...], a: Attitude
              ) -> tuple[float, float, float, float, float, float]:
        """``axes`` plus the PID output of each held tilt axis towards level; the integral
        is clamped to ± the hold's limit and frozen while the axis input saturates."""
        dt = 0.0 if math.isnan(self._t_hold) else max(0.0, a.t_s - self._t_hold)
        self._t_hold = a.t_s
        out = list(axes)
        for h in self.signal.hold:
            angle, rate = (a.phi, a.p) if h.axis == 3 else (a.theta, a.q)
            error = -angle
            saturated = abs(self._last[h.axis]) >= 1.0 if self._last else False
            if not (saturated and self._integral[h.axis] * error > 0):
                self._integral[h.axis] += error * dt
            i_term = max(-h.i_limit, min(h.i_limit, h.ki * self._integral[h.axis]))
            self._integral[h.axis] = i_term / h.ki
            out[h.axis] = max(-1.0, min(1.0, axes[h.axis] + h.kp * error + i_term
                                        - h.kd * rate))
        return (out[0], out[1], out[2], out[3], out[4], out[5])

    def _hold_depth(self, d: Depth, h: HoldAxis) -> None:
        """PI towards the start depth (heave input is positive down); the integral term is
        clamped to ± the hold's limit."""
        dt = 0.0 if math.isnan(self._t_depth) else max(0.0, d.t_s - self._t_depth)
        self._t_depth = d.t_s
        error = self._depth_ref - d.depth_m  # above the start depth: push down
        self._depth_integral += error * dt
        i_term = max(-h.i_limit, min(h.i_limit, h.ki * self._depth_integral))
        self._depth_integral = i_term / h.ki
        self._heave = h.kp * error + i_term

    def _check_time(self) -> list[Output[Never, Never]]:
        if self.phase.final:
            return []
        p = self.profile.procedure
        stop = self.guard.time(self._t) if self.phase is not Phase.CONNECT else None
        if stop is not None:
            return self._finish(Phase.FAILED, stop.reason, stop.cause)
        if (self.phase in (Phase.CONNECT, Phase.PRECHECK)
                and self._t - self._t_phase > p.connect_timeout_s):
            return self._finish(Phase.FAILED, "timeout: " + (self.reason or
                                                             "no vehicle answered"), Cause.TIMEOUT)
        return []

