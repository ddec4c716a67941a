"""The trim's session as ``trimd run`` builds it (:func:`trim_session`): the procedure, or
the verify hold of a target, with its recording, its ballast proposal and what it
announces to the ground station; the request is typed (:class:`TrimRequest`), not the
command line's arguments."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from trimd.app.announce import announce_run
from trimd.app.results import AnyPresenter
from trimd.app.session import Session
from trimd.app.verify import VerifyTarget, verify_procedure
from trimd.ballast.proposal import Proposal
from trimd.ballast.propose import propose_ballast
from trimd.ballast.verify import Verification
from trimd.core.estimate import StaticEstimate
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.profile_yaml import read_profile_text
from trimd.logs.recorder import TlogRecorder

__all__ = ["TrimRequest", "trim_session"]


@dataclass(frozen=True)
class TrimRequest:
    """What a trim is asked to do.

    Attributes
    ----------
    profile_ref : the profile as the operator named it (a YAML path or a shipped name):
        its text goes into the recording.
    confirmed : the operator confirmed up front (``--yes``).
    ballast_method : the proposal's method (:data:`trimd.ballast.propose.METHODS`).
    record : where to record the session (a ``.tlog``); None: not recorded.
    target : the verify target (:class:`trimd.app.verify.VerifyTarget`): a verify hold
        of that ballast instead of a trim; None: a trim.
    target_source : where the target came from, for people.
    """

    profile_ref: str
    confirmed: bool = False
    ballast_method: str = "milp"
    record: Path | None = None
    target: VerifyTarget | None = None
    target_source: str | None = None


def trim_session(link: Link, profile: Profile, presenters: list[AnyPresenter],
                 request: TrimRequest) -> Session[Proposal, Verification]:
    """The trim's session on ``link``, or the verify hold of ``request.target``."""
    target = request.target
    recorder = None
    if request.record is not None:
        recorder = TlogRecorder(request.record, profile,
                                read_profile_text(request.profile_ref)[0],
                                verify_target=None if target is None else target.to_dict())

    def propose(estimate: StaticEstimate) -> Proposal:
        return propose_ballast(estimate, profile, method=request.ballast_method)

    procedure = None if target is None else verify_procedure(
        profile, target, confirmed=request.confirmed,
        source=request.target_source or "the verify target")
    announce_run(link, presenters)  # the phases and the verdict for the ground station
    return Session(link, profile, recorder=recorder, presenters=presenters,
                   confirmed=request.confirmed, propose=propose, procedure=procedure)
