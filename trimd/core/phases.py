"""What every commanding state machine shares: its phase, when the phase began, how it
steps (an internal error still releases the vehicle) and how it ends (the trim
:class:`~trimd.core.procedure.Procedure` and the excitation experiment
:class:`~trimd.identify.experiment.Excite`); their precheck is
:class:`trimd.core.precheck.Precheck`."""

from __future__ import annotations

import math

from trimd.core.events import Cause, Event, Notice, Output, Phase
from trimd.core.guards import Guard
from trimd.core.samples import Release

__all__ = ["Phases"]


class Phases:
    """A phase with its reason, entered at the events' own time ``_t`` [s]; a subclass
    sets every attribute in its ``__init__`` (``_t`` and ``_t_phase`` NaN until the first
    event)."""

    phase: Phase
    reason: str
    cause: Cause
    guard: Guard
    _t: float
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

    def _enter(self, phase: Phase, text: str) -> list[Output]:
        """Enter ``phase`` now, saying ``text``."""
        self.phase = phase
        self._t_phase = self._t
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
