"""The TUI as a session presenter: keeps the live state and posts messages to the app.

The session calls it from its own task on the app's event loop; each call only updates
plain state and posts a message, so a fast link never blocks the UI.
"""

from __future__ import annotations

from textual.message_pump import MessagePump

from trimd.app.report import NewWarnings
from trimd.app.results import Finding
from trimd.ballast.proposal import Proposal
from trimd.core.events import Notice, Output, Progress
from trimd.core.samples import Health, Sample, VehicleText
from trimd.tui.messages import CommandSent, LinkMessage, NoticeReceived, TelemetryChanged
from trimd.tui.telemetry import LiveState

__all__ = ["TuiPresenter"]


class TuiPresenter:
    """Session presenter that feeds ``state`` and posts to ``target`` (the app)."""

    def __init__(self, target: MessagePump, state: LiveState) -> None:
        self.target = target
        self.state = state
        self._new_warnings = NewWarnings()

    def output(self, out: Output[Proposal, Finding], progress: Progress) -> None:
        if isinstance(out, Notice):
            self.target.post_message(NoticeReceived(out, progress))
        else:
            self.state.command(out)
            self.target.post_message(CommandSent(out, progress.t_s))

    def sample(self, sample: Sample, progress: Progress) -> None:
        if isinstance(sample, VehicleText):
            self.target.post_message(LinkMessage(sample.t_s, sample.level,
                                                 f"vehicle: {sample.text}"))
            return
        if isinstance(sample, Health):
            for warning in self._new_warnings(sample):
                self.target.post_message(LinkMessage(sample.t_s, "warning", warning))
        self.state.sample(sample)
        self.target.post_message(TelemetryChanged(progress))
