"""What follows a trim: its result stored in the trim history, the ballast the operator
installed recorded there (what ``trimd ballast apply`` does: :func:`trimd.app.apply.
apply_ballast`), a verify hold of the ballasted vehicle over the same link and, when it
finds the vehicle not level or not as predicted, the correction from what it measured
(:mod:`trimd.ballast.correct`), stored with it; applying that and verifying again is the
same apply and verify.

``trimd run`` builds one :class:`AfterTrim` per invocation; the TUI offers "apply" and
"verify" through it once a trim ends with a proposal. The verify hold is a new session on
a link opened again from the same URL, confirmed by the same rule as the trim (up front
with ``--yes``, else by the operator before anything is commanded), and recorded with its
verify target (:mod:`trimd.app.verify`) so that ``trimd replay`` reproduces its verdict.
"""

from __future__ import annotations

import contextlib
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Never, TypeVar

from trimd.app.announce import announce_run
from trimd.app.apply import Applied, apply_ballast
from trimd.app.float_check import float_correction, float_settings
from trimd.app.history import History
from trimd.app.history.calibration import record_float_reference, record_level_hold
from trimd.app.history.installed import current_installed
from trimd.app.history.trims import record_result, stored_text
from trimd.app.results import AnyPresenter, AnyResult, Finding
from trimd.app.session import Machine, Recorder, Session
from trimd.app.verify import VerifyTarget, verify_procedure
from trimd.ballast.correct import Correction, needs_correction, propose_correction
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import Verification
from trimd.core.errors import ProfileError
from trimd.core.estimate import StaticEstimate
from trimd.core.float_check import FloatCheck
from trimd.core.floating import FloatResult
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.types import JsonObject

__all__ = ["AfterTrim"]

#: A check's proposal and finding types (its session's: what the presenters take).
PT = TypeVar("PT", bound=Proposal)
VT = TypeVar("VT", bound=Finding)


@dataclass(frozen=True)
class AfterTrim:
    """Where a vehicle's results go and how its verify hold or float check starts.

    Attributes
    ----------
    db : the trim history file; None with ``--no-history`` (nothing stored, no apply).
    vehicle : the vehicle's key in the history.
    profile : the vehicle's profile (its ``installed`` ballast: the history's).
    confirmed : the operator confirmed up front (``--yes``): a verify hold does not wait
        for a confirmation either.
    open_link : opens the trim's link again (same URL).
    recorder : the recorder of a check (None: not recorded), given which (``verify`` or
        ``float``) and the block its recording carries (the verify target's document, the
        float check's settings).
    """

    db: Path | None
    vehicle: str
    profile: Profile
    confirmed: bool
    open_link: Callable[[], Awaitable[Link]]
    recorder: Callable[[str, JsonObject], Recorder | None]

    def store(self, result: AnyResult, correction: Correction | None = None
              ) -> str | None:
        """Store a session's estimate and proposal, or its verification or float check
        (with its ``correction``), in the history, with its level hold and, after a recorded ballast
        change, the calibration experiment it makes (:mod:`trimd.app.history.calibration`);
        a line for people (with the experiment's outcome), None when nothing was stored
        (no history, or a session that produced neither). DataError when the file cannot
        take it, ProfileError when its installed ballast is not the profile's."""
        if self.db is None or (result.estimate is None and result.verification is None):
            return None
        installed, _ = current_installed(self.db, self.vehicle, self.profile)
        with History(self.db) as history:
            record = record_result(history, self.vehicle, self.profile.name, result,
                                   correction=correction)
            outcome = None if record is None else record_level_hold(
                history, self.vehicle, self.profile, result, record, installed)
            if record is not None and isinstance(result.verification, FloatResult):
                outcome = record_float_reference(history, self.vehicle, self.profile,
                                                 result.verification, record, installed)
        stored = stored_text(self.vehicle, history.path)
        return stored if outcome is None else f"{stored}; {outcome.message}"

    def correct(self, v: Verification, target: VerifyTarget) -> Correction | None:
        """The correction after the verify hold ``v`` of ``target``, from the ballast
        installed now (the history's, else the profile's); None when the vehicle is level
        and as predicted. DataError for a history that does not fit the
        profile, ProfileError for installed pieces it does not have."""
        if not needs_correction(v):
            return None
        installed, _ = current_installed(self.db, self.vehicle, self.profile)
        return propose_correction(v, target.estimate, self.profile, installed)

    def apply(self, estimate: StaticEstimate, proposal: Proposal) -> Applied:
        """Record ``proposal`` (for ``estimate``) as the ballast now installed.
        ProfileError without a history; DataError when the history cannot take it or
        holds other ballast than the proposal started from."""
        if self.db is None:
            raise ProfileError("no trim history (--no-history): nothing can be recorded")
        return apply_ballast(self.db, self.vehicle, self.profile, estimate=estimate,
                             proposal=proposal)

    async def verify_session(self, target: VerifyTarget,
                             presenters: list[AnyPresenter]) -> Session[Never, Verification]:
        """A verify hold of ``target`` on the link opened again (not started). DataError
        for a target that does not fit the profile, LinkError when the link does not open,
        OSError when the recording cannot be created (the link is closed again)."""
        procedure = verify_procedure(self.profile, target, confirmed=self.confirmed)
        return await self._session(procedure, "verify", target.to_dict(), presenters)

    async def float_session(self, presenters: list[AnyPresenter]
                            ) -> Session[Never, FloatResult]:
        """A float check (:class:`trimd.core.float_check.FloatCheck`, the profile's depth
        envelope; for a correction, which the next steps offer unless it floats level) on
        the link opened again (not started). LinkError when the link does not open,
        OSError when the recording cannot be created (the link is closed again)."""
        check = FloatCheck(self.profile, confirmed=self.confirmed, for_correction=True)
        return await self._session(check, "float", float_settings(check), presenters)

    async def _session(self, procedure: Machine[PT, VT], kind: str, block: JsonObject,
                       presenters: list[AnyPresenter]) -> Session[PT, VT]:
        """``procedure``'s session on the link opened again, recorded as ``kind`` with
        ``block``."""
        link = await self.open_link()
        try:
            recorder = self.recorder(kind, block)
        except OSError:
            with contextlib.suppress(Exception):
                await link.close()
            raise
        announce_run(link, presenters)
        return Session(link, self.profile, recorder=recorder, presenters=presenters,
                       confirmed=self.confirmed, procedure=procedure)

    def correct_float(self, f: FloatResult, target: VerifyTarget) -> Correction | None:
        """The correction after the float check ``f`` of ``target``
        (:func:`trimd.app.float_check.float_correction`: from the ballast installed now);
        None when it floats level."""
        return float_correction(f, target, self.profile, self.db, self.vehicle)
