"""The trim procedure: a state machine driven by events, returning commands and notices.

Pure: no I/O, no clock. Every time is the events' own ``t_s`` (sample time), so the same
procedure runs live, against the simulator at 100× real time, and in a replay, with the
same result. The shells (headless daemon, TUI, tests) feed it samples, operator events
and :class:`Tick` events from their clock, and carry out what it returns.

Phases: connect → precheck → confirm → for each hold (settle → collect) → solve → done;
``failed`` or ``aborted`` from anywhere, always with a reason and a :class:`Release`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from trimd.core.decision import StopRule
from trimd.core.design import plan_extra_hold
from trimd.core.effort import HeldThrust
from trimd.core.errors import EstimationError
from trimd.core.estimate import HoldRecord, HoldSamples, StaticEstimate, estimate_static
from trimd.core.events import (
    Cause,
    Notice,
    Output,
    P,
    Phase,
    Progress,
    TrimResult,
    V,
)
from trimd.core.guards import Guard
from trimd.core.phases import Phases
from trimd.core.precheck import Precheck
from trimd.core.profile import HoldSetpoint, Profile
from trimd.core.ramp import TiltRamp
from trimd.core.samples import (
    Attitude,
    Battery,
    Depth,
    Health,
    HoldAttitude,
    Sample,
    Thrusters,
)
from trimd.core.settling import HoldSettling

__all__ = ["VERIFY_DONE", "Procedure"]

#: Telemetry the precheck needs, in samples per second of sample time.
MIN_RATES_HZ = {"attitude": 4.0, "thrusters": 2.0, "depth": 1.0}
#: The held heading trails the vehicle's own by at most this much [deg]: once the heading
#: is further off, the target moves to half this distance from it. A hold needs roll and
#: pitch, not a heading, and an absolute heading held at a tilt couples into them: a yaw
#: error is partly a tilt error there, so the roll and pitch loops chase it, and with the
#: horizontal thrusters idle in their deadband (a trimmed vehicle needs no yaw torque) the
#: simulated Heavy limit-cycled at 20°/20° (yaw ±15°, roll and pitch ±3.5°, period 12 s)
#: and the hold never settled. A leash, not a free heading: a vehicle whose offset centre
#: of gravity gives a yaw torque when tilted would otherwise turn all hold long.
HEADING_LEASH_DEG = 2.0
#: How a verify hold that reached its verdict ends (its last state notice says so).
VERIFY_DONE = "verify hold done"


class Procedure(Phases[P, V]):
    """The trim procedure for one vehicle described by ``profile``.

    Parameters
    ----------
    profile : holds, limits and timeouts (sample time) and the thruster model.
    confirmed : True when the operator confirmed up front (``--yes``).
    propose : called with the final estimate; its result rides on the result notice.
    verify : makes this a verify hold (after ballasting): only the profile's first hold
        (level), collected until its own rows are known, then ``verify`` is called with
        its samples instead of estimating; its result rides on the result notice.
    collect_s : collect each hold this long [s] instead of until the stop rule is met (a
        calibration's level holds: the stop rule stops once the noise is below the thrust
        map's share, the very errors a calibration measures, docs/method.md §7).

    The safety rules (:class:`trimd.core.guards.Guard`) are checked on every sample and
    Tick; whatever ends the procedure after the first command sends a Release.
    """

    def __init__(self, profile: Profile, *, confirmed: bool = False,
                 propose: Callable[[StaticEstimate], P] | None = None,
                 verify: Callable[[HoldSamples], V] | None = None,
                 collect_s: float | None = None) -> None:
        self.profile = profile
        self.proc = profile.procedure
        self.propose = propose
        self.verify = verify
        self.holds = profile.holds[:1] if verify else profile.holds
        self.verification: V | None = None
        self.phase = Phase.CONNECT
        self.reason = ""
        self.cause = Cause.NONE
        self.estimate: StaticEstimate | None = None
        self.proposal: P | None = None
        self.guard = Guard(profile.procedure, min_rates_hz=MIN_RATES_HZ)
        self.rule = StopRule.for_profile(profile)
        self.collect_s = collect_s
        if collect_s is not None:
            self.rule = dataclasses.replace(self.rule, looks_s=(collect_s,))
        self._confirmed = confirmed
        self._t = self._t_data = self._t_phase = math.nan
        self._health: Health | None = None
        self._held = HeldThrust(profile)
        self._depth: Depth | None = None
        self._attitude: Attitude | None = None
        self.precheck = Precheck(MIN_RATES_HZ, profile.procedure.max_depth_excursion_m)
        self._holds: list[HoldRecord] = []
        self._psi = 0.0
        self._tilt = TiltRamp(math.radians(self.proc.tilt_rate_deg_s),
                              math.radians(self.proc.attitude_tol_deg))
        self._settling: HoldSettling | None = None
        self._look = 0
        self._weighed = False

    # ---------------------------------------------------------------- public interface
    @property
    def progress(self) -> Progress:
        k = len(self._holds) - 1
        hold = self._holds[-1] if self._holds else None
        settled = 0.0
        since = self._settling.steady_since if self._settling else math.nan
        if self.phase is Phase.SETTLE and not math.isnan(since):
            settled = min(1.0, (self._t - since) / self.proc.min_steady_s)
        elif self.phase in (Phase.COLLECT, Phase.DONE):
            settled = 1.0
        return Progress(
            t_s=self._t, phase=self.phase, hold=max(k, 0), holds=len(self.holds),
            setpoint_deg=(math.degrees(hold.phi), math.degrees(hold.theta)) if hold else None,
            settled_fraction=settled, samples=len(hold.t) if hold else 0,
            time_left_s=self._time_left(self._t), message=self.reason)

    # ---------------------------------------------------------------- event handling
    def _on_sample(self, s: Sample) -> list[Output[P, V]]:
        self.precheck.sample(s)
        stop = self.guard.sample(s)
        if stop is not None:
            return self._finish(Phase.FAILED, stop.reason, cause=stop.cause)
        if isinstance(s, Health):
            self._health = s
        elif isinstance(s, Battery):
            self._held.battery(s)
        elif isinstance(s, Thrusters):
            self._held.outputs = s
            if self._settling is not None:
                tau = self._held.tau(s.t_s)
                if tau is not None:
                    self._settling.effort(s.t_s, tau)
        elif isinstance(s, Depth):
            self._depth = s
        elif isinstance(s, Attitude):
            self._attitude = s
            return self._on_attitude(s)
        return []

    def _on_attitude(self, a: Attitude) -> list[Output[P, V]]:
        if self.phase in (Phase.CONNECT, Phase.PRECHECK):
            return self._precheck()
        if self._settling is None or self.phase not in (Phase.SETTLE, Phase.COLLECT):
            return []
        if self.phase is Phase.COLLECT and self._time_left(self._t_data) < 0:
            return self._end_hold(self._decided())
        return self._command(a) + self._hold_sample(a, self._settling)

    def _command(self, a: Attitude) -> list[Output[P, V]]:
        """The hold's attitude command again when the ramp to it moved on
        (:class:`~trimd.core.ramp.TiltRamp`) or the held heading moved towards the
        vehicle's, which it may trail by at most :data:`HEADING_LEASH_DEG`."""
        moved = self._tilt.advance(a.t_s)
        error = math.remainder(self._psi - a.psi, math.tau)
        leash = math.radians(HEADING_LEASH_DEG)
        if abs(error) > leash:
            self._psi = a.psi + math.copysign(leash / 2, error)
        elif not moved:
            return []
        return [HoldAttitude(*self._commanded(), self._psi)]

    def _commanded(self) -> tuple[float, float]:
        """Roll and pitch [rad] commanded now."""
        return self._tilt.command or (0.0, 0.0)

    def _hold_sample(self, a: Attitude, settling: HoldSettling) -> list[Output[P, V]]:
        """An attitude sample during a hold: settle, collect, move on."""
        thrust, outputs = self._held.thrust(a.t_s), self._held.outputs
        if not settling.attitude(a, thrust is not None) or thrust is None or outputs is None:
            return []
        tau = self._held.T @ thrust
        if self.phase is Phase.SETTLE:
            if a.t_s - settling.steady_since >= self.proc.min_steady_s:
                return self._enter(Phase.COLLECT, f"hold {len(self._holds)} steady: collecting")
            return []
        hold = self._holds[-1]
        hold.t.append(a.t_s)
        hold.att.append((a.phi, a.theta))
        hold.tau.append(tau)
        hold.thrust.append(thrust)
        hold.pwm.append(outputs.pwm_us)
        hold.volts.append(self._held.voltage_V)
        return self._maybe_next_hold()

    # ---------------------------------------------------------------- phases
    def _ready(self) -> None:
        self._psi = self._attitude.psi if self._attitude else 0.0

    def _ready_text(self) -> str:
        return f"ready: confirm to let trimd command the vehicle ({len(self.holds)} holds)"

    def _start(self) -> list[Output[P, V]]:
        return self._next_hold()

    def _next_hold(self) -> list[Output[P, V]]:
        k = len(self._holds)
        sp = self.holds[k]
        phi, theta = math.radians(sp.roll_deg), math.radians(sp.pitch_deg)
        self._holds.append(HoldRecord(phi, theta))
        self._settling = HoldSettling(self.proc, phi, theta, self.rule.effort_floor(
            math.radians(self.proc.attitude_tol_deg), phi, theta))
        self._look = 0
        self.guard.start(self._now_data(), self._depth.depth_m if self._depth else math.nan,
                         "the hold's start depth")
        a = self._attitude
        self._tilt.toward(self._now_data(), (phi, theta), (a.phi, a.theta) if a else None)
        out: list[Output[P, V]] = [HoldAttitude(*self._commanded(), self._psi)]
        ramp = ("" if self._commanded() == (phi, theta)
                else f" at {self.proc.tilt_rate_deg_s:g}°/s")  # the ramp's rate
        return out + self._enter(Phase.SETTLE, f"hold {k + 1}/{len(self.holds)}: roll "
                                 f"{sp.roll_deg:g}°, pitch {sp.pitch_deg:g}°{ramp}")

    def _maybe_next_hold(self) -> list[Output[P, V]]:
        """After a collected sample: at each look of the stop rule, move on once the
        decision is known; at the last look (``collect_max_s``), move on anyway."""
        looks = self.rule.looks_s
        if self._look >= len(looks) or self._t_data - self._t_phase < looks[self._look]:
            return []
        self._look += 1
        decided = self._decided()
        if not decided and self._look < len(looks):
            return []
        return self._end_hold(decided)

    def _end_hold(self, confident: bool) -> list[Output[P, V]]:
        hold = self._holds[-1]
        if len(hold.t) < 2:
            return self._finish(Phase.FAILED, f"hold {len(self._holds)}: no steady sample "
                                              f"in {self.proc.collect_max_s:g} s of collecting",
                                cause=Cause.TIMEOUT)
        out: list[Output[P, V]] = []
        if not confident:
            out.append(Notice(self._t, "warning", f"hold {len(self._holds)}: the level "
                              f"tolerance ({self.profile.level_tol_deg:g}°) and the buoyancy "
                              "window were not reached at 95 % in collect_max_s; using what "
                              f"was collected ({len(hold.t)} samples): the ± says how well "
                              "the proposal is known"))
        if len(self._holds) < len(self.holds):
            return out + self._next_hold()
        if not self.verify and not self._weighed:
            self._weighed = True
            out += self._weigh_extra_hold()
            if len(self._holds) < len(self.holds):
                return out + self._next_hold()
        return out + self._solve()

    def _weigh_extra_hold(self) -> list[Output[P, V]]:
        """After the planned holds: when the dead band keeps the trim undecided, weigh a
        mirrored hold (:func:`trimd.core.design.plan_extra_hold`), add it when it is
        predicted to decide, and say what was chosen and why."""
        holds = self.hold_samples()
        last = self._holds[-1]
        try:
            plan = plan_extra_hold(holds, estimate_static(holds, self.profile), self.profile,
                                   self.profile.level_tol_deg,
                                   (math.degrees(last.phi), math.degrees(last.theta)))
        except EstimationError:
            return []
        if plan is None:
            return []
        if plan.add:
            self.holds = (*self.holds, HoldSetpoint(plan.roll_deg, plan.pitch_deg))
        return [Notice(self._t, "info", plan.message)]

    def _decided(self) -> bool:
        """Is what the operator acts on known well enough (:class:`StopRule`)? Before the
        last hold: this hold's mean effort on the rows that carry information at its
        attitude (at level: Z, K and M); at the last: the estimate. With ``collect_s``
        the hold's length is the decision: yes once it is over."""
        if self.collect_s is not None:
            return True
        if len(self._holds) < len(self.holds) or self.verify:
            hold = self._holds[-1]
            return self.rule.hold_decided(hold.samples(""), hold.phi, hold.theta)
        try:
            est = estimate_static(self.hold_samples(), self.profile)
        except EstimationError:
            return False
        return self.rule.estimate_decided(est)

    def _solve(self) -> list[Output[P, V]]:
        if self.verify:
            return self._verify(self.verify)
        try:
            self.estimate = estimate_static(self.hold_samples(), self.profile)
        except EstimationError as exc:
            return self._finish(Phase.FAILED, f"cannot solve: {exc}", cause=Cause.ESTIMATION)
        self.proposal = self.propose(self.estimate) if self.propose else None
        out = self._finish(Phase.DONE, "trim estimate ready")
        out.append(Notice(self._t, "result", "estimate",
                          result=TrimResult(self.estimate, self.proposal)))
        return out

    def _verify(self, verify: Callable[[HoldSamples], V]) -> list[Output[P, V]]:
        try:
            self.verification = verify(self.hold_samples()[0])
        except EstimationError as exc:
            return self._finish(Phase.FAILED, f"cannot verify: {exc}", cause=Cause.ESTIMATION)
        out = self._finish(Phase.DONE, VERIFY_DONE)
        out.append(Notice(self._t, "result", "verification", verification=self.verification))
        return out

    # ---------------------------------------------------------------- helpers
    def hold_samples(self) -> list[HoldSamples]:
        """The steady samples of each hold so far ("hold 1", …; a calibration experiment
        takes the level one, :mod:`trimd.core.calibration`)."""
        return [h.samples(f"hold {k + 1}") for k, h in enumerate(self._holds) if h.t]

    def _check_time(self) -> list[Output[P, V]]:
        if self.phase.final:
            return []
        stop = self.guard.time(self._t) if self.phase is not Phase.CONNECT else None
        if stop is not None:
            return self._finish(Phase.FAILED, stop.reason, cause=stop.cause)
        # collecting ends on attitude samples, never on a Tick: a replay without the live
        # shell's Ticks then reproduces the live result exactly
        if self._time_left(self._t) >= 0 or self.phase is Phase.COLLECT:
            return []
        if self.phase is Phase.SETTLE:
            what = f"hold {len(self._holds)} never settled ({self._why_unsteady()})"
        elif self.phase is Phase.PRECHECK:
            what = self.reason or "precheck did not pass"
        else:
            what = "no vehicle answered"
        return self._finish(Phase.FAILED, f"timeout: {what}", cause=Cause.TIMEOUT)

    def _why_unsteady(self) -> str:
        a, hold = self._attitude, self._holds[-1]
        if a is None:
            return "no attitude"
        return (f"roll {math.degrees(a.phi):.1f}° / pitch {math.degrees(a.theta):.1f}° for a "
                f"set-point of {math.degrees(hold.phi):.1f}° / {math.degrees(hold.theta):.1f}°"
                f", tolerance {self.proc.attitude_tol_deg}°")

    def _time_left(self, now: float) -> float:
        """What is left of the phase's time limit at ``now`` [s]: ``_t`` for the timeouts,
        ``_t_data`` for the collect limit (the samples end a hold, never a Tick)."""
        limit = {Phase.CONNECT: self.proc.connect_timeout_s,
                 Phase.PRECHECK: self.proc.connect_timeout_s,
                 Phase.SETTLE: self.proc.settle_timeout_s,
                 Phase.COLLECT: self.proc.collect_max_s}.get(self.phase)
        if limit is None or math.isnan(now):
            return math.inf
        return limit - (now - self._t_phase)

