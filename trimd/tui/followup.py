"""The TUI after a session: store its result in the trim history and, once a trim ends
with a proposal, offer "apply" and "verify" (:class:`trimd.app.after_trim.AfterTrim`);
once a verify hold finds the vehicle not level or not as predicted, offer its correction
(:mod:`trimd.ballast.correct`) the same way: apply, then verify again.

Apply records the ``milp`` proposal (pieces of the inventory; the other methods' ideal
amounts cannot be installed as such) as the installed ballast, and shows it.
Verify opens the trim's link again and hands the app a verify-hold session, which runs
on the main screen as the trim did: nothing is commanded before the operator confirms
(``s``, unless ``--yes``), ``a`` aborts, quitting asks first; its verdict then shows.
"""

from __future__ import annotations

from collections.abc import Callable

from textual.app import App

from trimd.app.after_trim import AfterTrim
from trimd.app.apply import Applied
from trimd.app.report import format_applied
from trimd.app.results import AnyResult, AnySession
from trimd.app.verify import VerifyTarget
from trimd.ballast.correct import Correction
from trimd.ballast.propose import Proposal, propose_ballast
from trimd.ballast.verify import Verification
from trimd.core.errors import TrimdError
from trimd.core.estimate import StaticEstimate
from trimd.core.events import Phase
from trimd.core.profile import Profile
from trimd.tui.event_log import EventLog
from trimd.tui.next_steps import NextSteps
from trimd.tui.result_panel import ResultPanel
from trimd.tui.telemetry import LiveState
from trimd.tui.verdict_panel import VerdictPanel

__all__ = ["APPLIED_METHOD", "Followup"]

#: The proposal apply records: pieces of the inventory, what can be installed (the other
#: methods give ideal continuous amounts), as ``trimd ballast apply`` records it.
APPLIED_METHOD = "milp"


class Followup:
    """What the app does after each session; ``after`` None: nothing (a replay).

    ``app`` is the TUI (its panels, bindings and workers), ``state`` its live state (the
    clock of the log's lines), ``start_verify`` runs a verify hold's session on the main
    screen (:meth:`trimd.tui.app.TrimApp.run_session`)."""

    def __init__(self, app: App[AnyResult], profile: Profile, state: LiveState,
                 start_verify: Callable[[AnySession], None], after: AfterTrim | None) -> None:
        self.app = app
        self.profile = profile
        self.state = state
        self.start_verify = start_verify
        self.after = after
        self.running = True  # a session runs (the app starts one at once)
        self.trim: AnyResult | None = None  # the trim whose proposal is offered
        self.applied: Applied | None = None
        self.target: VerifyTarget | None = None  # what a verify hold checks
        self.correction: Correction | None = None  # a verify hold's, offered to apply
        self.opening = False

    def _log(self, kind: str, text: str) -> None:
        self.app.query_one(EventLog).add(self.state.t_s, kind, text)

    def ended(self, r: AnyResult) -> None:
        """A session ended: a verify hold shows its verdict (a replayed one too); with
        ``after``, it is stored, and a trim with a proposal offers apply."""
        self.running = False
        if isinstance(r.verification, Verification):
            self.app.query_one(VerdictPanel).show(r.verification)
            self.app.add_class("-verdict", "-result")
            self._log("result", r.verification.message)
        if self.after is None:
            return
        correction = self._correct(r)
        try:
            stored = self.after.store(r, correction)
        except TrimdError as exc:
            self._log("error", f"not stored in the trim history: {exc}")
            self.app.notify(f"not stored in the trim history: {exc}", severity="error")
        else:
            if stored:
                self._log("info", stored)
        steps = self.app.query_one(NextSteps)
        if self.target is not None:  # the verify hold this offered ended
            self.correction = correction
            steps.verified(r.verification if isinstance(r.verification, Verification)
                           else None, r.reason, correction)
        elif r.phase is Phase.DONE and r.proposal is not None:
            self.trim = r
            if self.after.db is None:
                steps.unavailable("apply and verify record in the trim history: "
                                  "not with --no-history")
            else:
                steps.offer(APPLIED_METHOD, self.after.vehicle)

    def _correct(self, r: AnyResult) -> Correction | None:
        """The correction after a verify hold this offered (None: none needed, or none
        can be proposed, which the log says)."""
        if (self.after is None or self.target is None
                or not isinstance(r.verification, Verification)):
            return None
        try:
            correction = self.after.correct(r.verification, self.target)
        except TrimdError as exc:
            self._log("error", f"no correction proposed: {exc}")
            return None
        if correction is not None:
            self._log("result", f"correction: {correction.proposal.message}")
        return correction

    @property
    def can_apply(self) -> bool:
        return (self.after is not None and self.after.db is not None
                and not self.running and (self.correction is not None or (
                    self.trim is not None and self.applied is None)))

    @property
    def can_verify(self) -> bool:
        return self.target is not None and not self.running and not self.opening

    def apply(self) -> None:
        """Record the proposal on offer as the installed ballast and show it: a verify
        hold's correction, else the trim's ``milp`` proposal."""
        if self.after is None or (self.correction is None and (
                self.trim is None or self.trim.estimate is None)):
            return
        panel = self.app.query_one(ResultPanel)
        try:
            estimate, proposal = self._offered(panel)
            self.applied = self.after.apply(estimate, proposal)
        except (TrimdError, ValueError) as exc:
            self._log("error", f"apply: {exc}")
            self.app.query_one(NextSteps).failed(f"apply: {exc}", "p", "apply again")
            return
        if self.correction is None:
            panel.proposals[APPLIED_METHOD] = proposal
            panel.method = APPLIED_METHOD  # what was recorded is what is shown
        self.correction = None
        self.target = VerifyTarget(estimate, tuple(self.applied.loads))
        for line in format_applied(self.applied).splitlines():
            self._log("info", line)
        self.app.query_one(NextSteps).applied(self.applied)

    def _offered(self, panel: ResultPanel) -> tuple[StaticEstimate, Proposal]:
        """The proposal :meth:`apply` records and the estimate it is for."""
        if self.correction is not None:
            return self.correction.vehicle, self.correction.proposal
        assert self.trim is not None and self.trim.estimate is not None
        return self.trim.estimate, panel.proposals.get(APPLIED_METHOD) or propose_ballast(
            self.trim.estimate, self.profile, method=APPLIED_METHOD)

    def cancel(self) -> None:
        """The operator aborted while the link was being opened: no verify hold starts."""
        if self.opening:
            self.app.workers.cancel_group(self.app, "verify")
            self.opening = False
            self._log("error", "verify cancelled by the operator before it started")
            self.app.query_one(NextSteps).failed("verify cancelled", "y", "verify again")
            self.app.refresh_bindings()

    async def verify(self) -> None:
        """Open the link again and start the verify hold on the main screen."""
        if self.after is None or self.target is None:
            return
        self.opening = True
        self.app.refresh_bindings()
        steps = self.app.query_one(NextSteps)
        steps.verifying("the link (opening…)")
        try:
            session = await self.after.verify_session(self.target, [])
        except (TrimdError, OSError) as exc:
            self._log("error", f"verify: {exc}")
            steps.failed(f"verify: {exc}", "y", "verify again")
            return
        finally:
            self.opening = False
            self.app.refresh_bindings()
        steps.verifying(getattr(session.link, "description", "the link"))
        self.app.query_one(VerdictPanel).remove_class("-off")
        self.app.remove_class("-verdict", "-result")
        self._log("state", "verify hold: a level hold of the ballasted vehicle")
        self.running = True
        self.start_verify(session)
