"""Messages from the session (via :class:`~trimd.tui.presenter.TuiPresenter`) and the
ballast worker to the app. Telemetry arrives at the link's rate, so
:class:`TelemetryChanged` carries no data (the state lives in
:class:`~trimd.tui.telemetry.LiveState`) and a newer one replaces any still queued: a
slow terminal coalesces them instead of falling behind (toolong's ``messages.py``)."""

from __future__ import annotations

from dataclasses import dataclass

from textual.message import Message

from trimd.app.results import AnyResult, Finding
from trimd.ballast.proposal import Proposal
from trimd.core.events import Notice, Progress
from trimd.core.samples import Command

__all__ = ["CommandSent", "LinkMessage", "NoticeReceived", "ProposalReady", "SessionEnded",
           "TelemetryChanged"]


@dataclass
class TelemetryChanged(Message):
    """New samples are in the live state; ``progress`` is the procedure's latest."""

    progress: Progress

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, TelemetryChanged)


@dataclass
class NoticeReceived(Message):
    """A state change, information, warning or the result (never coalesced)."""

    notice: Notice[Proposal, Finding]
    progress: Progress


@dataclass
class LinkMessage(Message):
    """A link warning or a vehicle's own message for the Messages panel (never
    coalesced): ``kind`` is warning, error or info, as :class:`EventLog` styles them."""

    t_s: float
    kind: str
    text: str


@dataclass
class CommandSent(Message):
    """The session sent ``command`` to the vehicle at sample time ``t_s``."""

    command: Command
    t_s: float


@dataclass
class SessionEnded(Message):
    """The session returned: the vehicle is released and the log closed."""

    result: AnyResult


@dataclass
class ProposalReady(Message):
    """The ballast worker finished ``method``: a ``trimd.ballast.propose.Proposal``, or None and
    the error that stopped it."""

    method: str
    proposal: Proposal | None
    error: str = ""
