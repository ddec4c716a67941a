"""The TUI after a session: store its result in the trim history and, once a trim ends
with a proposal, offer "apply", then "verify" or "float"
(:class:`trimd.app.after_trim.AfterTrim`); once a verify hold finds the vehicle not level
or not as predicted, or a float check finds it floating not level, offer its correction
(:mod:`trimd.ballast.correct`) the same way: apply, then check again.

Apply records the ``milp`` proposal (pieces of the inventory; the other methods' ideal
amounts cannot be installed as such) as the installed ballast, and shows it.
Verify (a level hold through the thrusters) and float (the thrusters at neutral: the
attitude the vehicle floats at, no thrust map; docs/method.md §8) open the trim's link
again and hand the app the check's session, which runs on the main screen as the trim
did: nothing is commanded before the operator confirms (``s``, unless ``--yes``), ``a``
aborts, quitting asks first; its verdict then shows.
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
from trimd.core.floating import FloatResult
from trimd.core.profile import Profile
from trimd.tui.event_log import EventLog
from trimd.tui.next_steps import NextSteps
from trimd.tui.result_panel import ResultPanel
from trimd.tui.telemetry import LiveState
from trimd.tui.verdict_panel import VerdictPanel

__all__ = ["APPLIED_METHOD", "CHECKS", "Followup"]

#: The proposal apply records: pieces of the inventory, what can be installed (the other
#: methods give ideal continuous amounts), as ``trimd ballast apply`` records it.
APPLIED_METHOD = "milp"
#: The checks after apply: their key, what they are called, and what the log says as one
#: starts.
CHECKS = {"verify": ("y", "verify hold", "verify hold: a level hold of the ballasted vehicle"),
          "float": ("f", "float check", "float check: the thrusters at neutral, the "
                    "ballasted vehicle floats")}


class Followup:
    """What the app does after each session; ``after`` None: nothing (a replay).

    ``app`` is the TUI (its panels, bindings and workers), ``state`` its live state (the
    clock of the log's lines), ``start`` runs a check's session on the main screen, given
    its kind (:meth:`trimd.tui.app.TrimApp.run_session`)."""

    def __init__(self, app: App[AnyResult], profile: Profile, state: LiveState,
                 start: Callable[[AnySession, str], None], after: AfterTrim | None) -> None:
        self.app = app
        self.profile = profile
        self.state = state
        self.start = start
        self.after = after
        self.running = True  # a session runs (the app starts one at once)
        self.trim: AnyResult | None = None  # the trim whose proposal is offered
        self.applied: Applied | None = None
        self.target: VerifyTarget | None = None  # what a check checks
        self.correction: Correction | None = None  # a check's, offered to apply
        self.opening = False
        self.kind = "verify"  # the check being opened, or the last one

    def _log(self, kind: str, text: str) -> None:
        self.app.query_one(EventLog).add(self.state.t_s, kind, text)

    def ended(self, r: AnyResult) -> None:
        """A session ended: a verify hold or a float check shows its verdict (a replayed
        one too); with ``after``, it is stored, and a trim with a proposal offers apply."""
        self.running = False
        v = r.verification if isinstance(r.verification, Verification | FloatResult) else None
        if v is not None:
            self.app.query_one(VerdictPanel).show(v)
            self.app.add_class("-verdict", "-result")
            self._log("result", v.message)
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
        if self.target is not None:  # the check this offered ended
            self.correction = correction
            steps.checked(v, r.reason, correction)
        elif r.phase is Phase.DONE and r.proposal is not None:
            self.trim = r
            if self.after.db is None:
                steps.unavailable("apply and verify record in the trim history: "
                                  "not with --no-history")
            else:
                steps.offer(APPLIED_METHOD, self.after.vehicle)

    def _correct(self, r: AnyResult) -> Correction | None:
        """The correction after a verify hold or a float check this offered (None: none
        needed, or none can be proposed, which the log says)."""
        v = r.verification
        if self.after is None or self.target is None:
            return None
        try:
            if isinstance(v, Verification):
                correction = self.after.correct(v, self.target)
            elif isinstance(v, FloatResult):
                correction = self.after.correct_float(v, self.target)
            else:
                return None
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
        """The operator aborted while the link was being opened: no check starts."""
        if self.opening:
            self.app.workers.cancel_group(self.app, "verify")
            self.opening = False
            kind = self.kind
            self._log("error", f"{kind} cancelled by the operator before it started")
            self.app.query_one(NextSteps).failed(f"{kind} cancelled", CHECKS[kind][0],
                                                 f"{kind} again")
            self.app.refresh_bindings()

    async def check(self, kind: str) -> None:
        """Open the link again and start the check ``kind`` (:data:`CHECKS`: a verify
        hold or a float check) on the main screen."""
        if self.after is None or self.target is None:
            return
        key, what, log = CHECKS[kind]
        self.opening, self.kind = True, kind
        self.app.refresh_bindings()
        steps = self.app.query_one(NextSteps)
        steps.checking(what, "the link (opening…)")
        try:
            session: AnySession
            if kind == "verify":
                session = await self.after.verify_session(self.target, [])
            else:
                session = await self.after.float_session([])
        except (TrimdError, OSError) as exc:
            self._log("error", f"{kind}: {exc}")
            steps.failed(f"{kind}: {exc}", key, f"{kind} again")
            return
        finally:
            self.opening = False
            self.app.refresh_bindings()
        steps.checking(what, getattr(session.link, "description", "the link"))
        self.app.query_one(VerdictPanel).remove_class("-off")
        self.app.remove_class("-verdict", "-result")
        self._log("state", log)
        self.running = True
        self.start(session, kind)
