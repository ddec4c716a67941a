"""What every commanding state machine shares: its phase, when the phase began, how it
steps (an internal error still releases the vehicle) and how it ends (the trim
:class:`~trimd.core.procedure.Procedure` and the excitation experiment
:class:`~trimd.identify.experiment.Excite`); their precheck is
:class:`trimd.core.precheck.Precheck`."""

from __future__ import annotations

import math

from trimd.core.events import Cause, Event, Notice, Output, Phase, Tick
from trimd.core.guards import Guard
from trimd.core.samples import Release, Sample

__all__ = ["Phases"]


class Phases:
    """A phase with its reason. Two clocks [s]: ``_t``, the latest event's time, Ticks
    included (timeouts run on it, so a silent link still ends the machine), and
    ``_t_data``, the latest sample's time: a phase begins, and everything the samples
    decide is timed, on ``_t_data`` alone, so a replay, which has no Ticks, decides as the
    live run did however late the live shell's event loop ran. A subclass sets every
    attribute in its ``__init__`` (the times NaN until the first event) and calls
    :meth:`_clock` on each timed event."""

    phase: Phase
    reason: str
    cause: Cause
    guard: Guard
    _t: float
    _t_data: float
    _t_phase: float

    def step(self, event: Event) -> list[Output]:
        """Advance on one event; return the commands to send and notices to show. Any
        internal error ends the machine FAILED, releasing the vehicle first."""
        if self.phase.final:
            return []
        try:
            return self._step(event)
        except Exception as exc:  # any internal error must still release the vehicle
            return self._finish(Phase.FAILED, f"internal error: {type(exc).__name__}: {exc}",
                                cause=Cause.INTERNAL)

    def _step(self, event: Event) -> list[Output]:
        """One event, the machine's own way."""
        raise NotImplementedError

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

    def _enter(self, phase: Phase, text: str) -> list[Output]:
        """Enter ``phase`` at the latest sample's time, saying ``text``."""
        self.phase = phase
        self._t_phase = self._now_data()
        self.reason = text
        return [Notice(self._t, "state", text, phase)]

    def _finish(self, phase: Phase, reason: str, cause: Cause = Cause.NONE) -> list[Output]:
        """End in ``phase`` with a :class:`Release` first while trimd commands;
        ``cause`` lets a shell choose its exit code."""
        if math.isnan(self._t):  # ended before any sample: at session time 0
            self._t = 0.0
        self.cause = cause
        commanding = self.guard.commanding and not self.phase.final
        self.guard.commanding = False
        out: list[Output] = [Release()] if commanding else []
        return out + self._enter(phase, reason)
