"""The result types of the application's sessions, named once.

A session's machine (:class:`trimd.app.session.Machine`) gives a proposal and a finding on
its result notices; in the application the proposal is a ballast
:class:`~trimd.ballast.proposal.Proposal` and the finding one of :data:`Finding`.
"""

from __future__ import annotations

from typing import Protocol, TypeAlias

from trimd.app.session import Machine, Presenter, Recorder, SessionResult
from trimd.ballast.proposal import Proposal
from trimd.ballast.verify import Verification
from trimd.core.estimate import HoldSamples
from trimd.core.floating import FloatResult
from trimd.core.link import Link

__all__ = ["AnyPresenter", "AnyResult", "AnySession", "Finding"]

#: What a machine's check found: a verify hold's verdict, a float check's result, or a
#: calibration's level hold (its samples).
Finding: TypeAlias = Verification | FloatResult | HoldSamples
#: A session's end, whatever its kind, as a shell that runs several kinds sees it.
AnyResult: TypeAlias = SessionResult[Proposal, Finding]
#: A presenter of any session (the headless printer, the TUI's).
AnyPresenter: TypeAlias = Presenter[Proposal, Finding]


class AnySession(Protocol):
    """A :class:`trimd.app.session.Session` of any kind, as a shell that runs several kinds
    drives it (the TUI: a trim, its verify holds, a replay of any recording)."""

    @property
    def link(self) -> Link: ...

    @property
    def recorder(self) -> Recorder | None: ...

    @property
    def procedure(self) -> Machine[Proposal, Finding]: ...

    async def run(self) -> AnyResult: ...

    def add_presenter(self, presenter: AnyPresenter) -> None: ...

    def confirm(self) -> None: ...

    def abort(self, reason: str = ...) -> None: ...
