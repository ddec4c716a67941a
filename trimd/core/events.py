"""What the state machines (the trim procedure, the excitation experiment) take in and give
out, besides samples and commands: operator and clock events, notices, progress, and why
a session ended. Every time is sample time [s] (session time, from the first heartbeat).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Generic, TypeAlias, TypeVar

from trimd.core.estimate import StaticEstimate
from trimd.core.samples import Command, Sample

__all__ = ["Abort", "Cause", "Confirm", "Event", "Notice", "Output", "P", "Phase", "Progress",
           "Tick", "TrimResult", "V"]

#: What a trim's proposer made of its estimate (the application's ballast proposal).
P = TypeVar("P", covariant=True)
#: What a machine's check found (the application's verification, a float check's result, a
#: calibration's level hold).
V = TypeVar("V", covariant=True)


class Phase(Enum):
    CONNECT = "connect"
    PRECHECK = "precheck"
    CONFIRM = "confirm"
    SETTLE = "settle"
    COLLECT = "collect"
    DONE = "done"
    FAILED = "failed"
    ABORTED = "aborted"

    @property
    def final(self) -> bool:
        return self in (Phase.DONE, Phase.FAILED, Phase.ABORTED)


class Cause(StrEnum):
    """Why a session ended, for a shell choosing its exit code (``NONE`` when done)."""

    NONE = ""
    OPERATOR = "operator"
    PILOT = "pilot"
    LINK = "link"
    VEHICLE = "vehicle"
    ENVELOPE = "envelope"
    TIMEOUT = "timeout"
    ESTIMATION = "estimation"
    INTERNAL = "internal"


@dataclass(frozen=True, slots=True)
class Tick:
    """The shell's clock [s] on the samples' time base: lets timeouts fire without data."""

    t_s: float


@dataclass(frozen=True, slots=True)
class Confirm:
    """The operator allows trimd to command the vehicle."""


@dataclass(frozen=True, slots=True)
class Abort:
    """The operator (or the shell, on a signal) stops the procedure."""

    reason: str = "aborted by the operator"


Event = Sample | Tick | Confirm | Abort


@dataclass(frozen=True, slots=True)
class TrimResult(Generic[P]):
    """The estimate, and the ballast proposal made from it (the proposer's value: a
    :class:`trimd.ballast.proposal.Proposal` in the application, None without one)."""

    estimate: StaticEstimate
    proposal: P | None


@dataclass(frozen=True, slots=True)
class Notice(Generic[P, V]):
    """Something for the presenters: ``kind`` is state, info, warning or result.

    ``phase`` is the phase a state notice enters; ``result`` rides on the result notice
    of a trim, ``verification`` on that of a machine's check (the checker's value: a
    :class:`trimd.ballast.verify.Verification` after a verify hold in the application).
    """

    t_s: float
    kind: str
    text: str
    phase: Phase | None = None
    result: TrimResult[P] | None = None
    verification: V | None = None


@dataclass(frozen=True, slots=True)
class Progress:
    """Where the procedure is, for a progress bar or a status line."""

    t_s: float
    phase: Phase
    hold: int
    holds: int
    setpoint_deg: tuple[float, float] | None
    settled_fraction: float
    samples: int
    time_left_s: float
    message: str


#: What a machine gives out: commands for the vehicle, notices for the presenters (with its
#: result's types).
Output: TypeAlias = Command | Notice[P, V]
