"""What every commanding state machine shares: its phase, when the phase began, how it
steps (an internal error still releases the vehicle), how it gets to command (the vehicle
present, the precheck :class:`trimd.core.precheck.Precheck` passed, the operator's
confirmation) and how it ends (the trim :class:`~trimd.core.procedure.Procedure`, the
float check :class:`~trimd.core.float_check.FloatCheck` and the excitation experiment
:class:`~trimd.identify.experiment.Excite`)."""

from __future__ import annotations

import math
from typing import Generic

from trimd.core.events import Abort, Cause, Confirm, Event, Notice, Output, P, Phase, Tick, V
from trimd.core.guards import Guard
from trimd.core.precheck import PRECHECK_WINDOW_S, Precheck
from trimd.core.samples import Health, Release, Sample

__all__ = ["Phases"]


class Phases(Generic[P, V]):
    """A phase with its reason. Two clocks [s]: ``_t``, the latest event's time, Ticks
    included (timeouts run on it, so a silent link still ends the machine), and
    ``_t_data``, the latest sample's time: a phase begins, and everything the samples
    decide is timed, on ``_t_data`` alone, so a replay, which has no Ticks, decides as the
    live run did however late the live shell's event loop ran. A subclass sets every
    attribute in its ``__init__`` (the times NaN until the first event), calls
    :meth:`_clock` on each timed event, :meth:`_precheck` on the samples before it
    commands and :meth:`_on_confirm` on the operator's Confirm, and says how it starts
    (:meth:`_start`) and what the operator confirms (:meth:`_ready_text`)."""

    phase: Phase
    reason: str
    cause: Cause
    guard: Guard
    precheck: Precheck
    _health: Health | None
    _confirmed: bool
    _t: float
    _t_data: float
    _t_phase: float

    def step(self, event: Event) -> list[Output[P, V]]:
        """Advance on one event; return the commands to send and notices to show. Any
        internal error ends the machine FAILED, releasing the vehicle first."""
        if self.phase.final:
            return []
        try:
            return self._step(event)
        except Exception as exc:  # any internal error must still release the vehicle
            return self._finish(Phase.FAILED, f"internal error: {type(exc).__name__}: {exc}",
                                cause=Cause.INTERNAL)

    def _step(self, event: Event) -> list[Output[P, V]]:
        """One event: an Abort ends the machine (releasing the vehicle), a Confirm is the
        operator's go (:meth:`_on_confirm`); a sample (:meth:`_on_sample`) or a Tick
        advances the clocks, then the timeouts are checked (:meth:`_check_time`)."""
        if isinstance(event, Abort):
            return self._finish(Phase.ABORTED, event.reason, cause=Cause.OPERATOR)
        if isinstance(event, Confirm):
            return self._on_confirm()
        self._clock(event)
        out = [] if isinstance(event, Tick) else self._on_sample(event)
        return out if self.phase.final else out + self._check_time()

    def _on_sample(self, s: Sample) -> list[Output[P, V]]:
        """One sample, the machine's own way."""
        raise NotImplementedError

    def _check_time(self) -> list[Output[P, V]]:
        """The timeouts at the latest event's time, the machine's own way."""
        raise NotImplementedError

    def _start(self) -> list[Output[P, V]]:
        """Begin commanding (the precheck passed, the operator confirmed)."""
        raise NotImplementedError

    def _ready_text(self) -> str:
        """What the operator is asked to confirm."""
        raise NotImplementedError

    def _ready(self) -> None:
        """The precheck has passed (before the confirmation): note what the start needs."""

    def _precheck(self) -> list[Output[P, V]]:
        """Before commanding: CONNECT → PRECHECK once the vehicle is present; then, once
        the precheck has held for :data:`PRECHECK_WINDOW_S` of the samples' time, start
        when confirmed up front, else ask (CONFIRM); until it passes, the reason says
        what it waits for."""
        h = self._health
        if self.phase not in (Phase.CONNECT, Phase.PRECHECK) or h is None or not h.connected:
            return []
        if self.phase is Phase.CONNECT:
            return self._enter(Phase.PRECHECK, f"vehicle present (mode {h.mode})")
        if self._t_data - self._t_phase < PRECHECK_WINDOW_S:
            return []
        problems = self.precheck.problems(self._t_data)
        if problems:
            self.reason = "waiting: " + "; ".join(problems)
            return []
        self._ready()
        if self._confirmed:
            return self._start()
        return self._enter(Phase.CONFIRM, self._ready_text())

    def _on_confirm(self) -> list[Output[P, V]]:
        """The operator's go. Given in the confirm phase, the precheck is run again (the
        vehicle may have changed while the operator thought); given earlier, it stands
        for the moment the precheck passes."""
        if self.phase is not Phase.CONFIRM:
            self._confirmed = True
            return []
        problems = self.precheck.problems(self._t_data)
        if problems:
            return self._enter(Phase.PRECHECK, "cannot start: " + "; ".join(problems)
                               + " (confirm again when ready)")
        self._confirmed = True
        return self._start()

    def _clock(self, event: Sample | Tick) -> None:
        """Advance the clocks to a timed ``event`` (a sample or a Tick); the first one
        begins the first phase."""
        if math.isnan(self._t_phase):
            self._t_phase = event.t_s
        self._t = event.t_s if math.isnan(self._t) else max(self._t, event.t_s)
        if not isinstance(event, Tick):
            self._t_data = (event.t_s if math.isnan(self._t_data)
                            else max(self._t_data, event.t_s))

    def _now_data(self) -> float:
        """The latest sample's time, or the latest event's before any sample [s]."""
        return self._t if math.isnan(self._t_data) else self._t_data

    def _enter(self, phase: Phase, text: str) -> list[Output[P, V]]:
        """Enter ``phase`` at the latest sample's time, saying ``text``."""
        self.phase = phase
        self._t_phase = self._now_data()
        self.reason = text
        return [Notice(self._t, "state", text, phase)]

    def _finish(self, phase: Phase, reason: str, cause: Cause = Cause.NONE) -> list[Output[P, V]]:
        """End in ``phase`` with a :class:`Release` first while trimd commands;
        ``cause`` lets a shell choose its exit code."""
        if math.isnan(self._t):  # ended before any sample: at session time 0
            self._t = 0.0
        self.cause = cause
        commanding = self.guard.commanding and not self.phase.final
        self.guard.commanding = False
        out: list[Output[P, V]] = [Release()] if commanding else []
        return out + self._enter(phase, reason)
