"""The trimd terminal UI: the session runs in a worker on the app's loop; the TUI is
one of its presenters. :func:`make_app` builds it for ``trimd run`` / ``trimd demo`` /
``trimd replay`` (which run it until the operator quits or a signal stops it) and for the
tests. After a trim that ends with a proposal, ``trimd run``'s TUI offers apply, then a
verify hold or a float check (:mod:`trimd.tui.followup`): each check is a second session
on the same screen."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import ClassVar

from textual import on
from textual.app import App, ComposeResult, SystemCommand
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical
from textual.css.query import NoMatches
from textual.events import Resize
from textual.screen import Screen
from textual.widgets import Footer

from trimd.app.after_trim import AfterTrim
from trimd.app.report import NewCommands
from trimd.app.results import AnyResult, AnySession
from trimd.ballast.propose import METHODS
from trimd.core.events import Phase, Progress
from trimd.core.profile import Profile
from trimd.tui.attitude_panel import AttitudePanel
from trimd.tui.event_log import EventLog
from trimd.tui.followup import Followup
from trimd.tui.help_screen import HelpScreen
from trimd.tui.link_panel import HEARTBEAT_STALE_S, LinkPanel
from trimd.tui.messages import (
    CommandSent,
    LinkMessage,
    NoticeReceived,
    SessionEnded,
    TelemetryChanged,
)
from trimd.tui.next_steps import NextSteps
from trimd.tui.presenter import TuiPresenter
from trimd.tui.quit_screen import QuitScreen
from trimd.tui.replay_pace import PacedReplay
from trimd.tui.report import Report, save_report
from trimd.tui.result_panel import ResultPanel
from trimd.tui.stepper import Stepper
from trimd.tui.telemetry import LiveState
from trimd.tui.thrusters import ThrusterPanel
from trimd.tui.verdict_panel import VerdictPanel

__all__ = ["TrimApp", "make_app"]

#: At least this many columns and rows show the live view and the result together
#: (class ``-roomy`` on the app; ``-result`` shows the result alone).
ROOMY = (110, 36)
#: Live panels are redrawn at most this often [Hz, wall clock]: display pacing only.
REDRAW_HZ = 10.0
_BEFORE_HOLDS = (Phase.CONNECT, Phase.PRECHECK, Phase.CONFIRM)


class TrimApp(App[AnyResult]):
    """Runs ``session`` and shows it; ``result`` is set once the session has ended.

    ``replay``: the session's link when it replays a recording (pause and speed keys).
    ``after``: where results go and how a check starts (None: no apply, verify or float).
    ``results``: every session's result, the trim's first (the checks' after it)."""

    CSS_PATH = "trimd.tcss"
    TITLE = "trimd"
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("s", "start", "Start/confirm"),
        # priority: works on every screen (modal ones too), except where a text input
        # consumes the key (the command palette's search offers ABORT itself)
        Binding("a", "abort", "ABORT", priority=True),
        Binding("m", "method", "Method"),
        Binding("v", "view", "Live/result"),
        Binding("r", "report", "Save report"),
        Binding("p", "apply", "Apply ballast"),
        Binding("y", "verify", "Verify"),
        Binding("f", "float", "Float", show=False),  # the next-steps panel offers it
        # a replay's only (hidden over a live link)
        Binding("space", "pace('pause')", "Pause"),
        Binding("plus,equals_sign", "pace('faster')", "Faster", key_display="+"),
        Binding("minus", "pace('slower')", "Slower", key_display="-"),
        Binding("question_mark,f1", "help", "Help", key_display="?"),
        Binding("q,ctrl+c", "quit", "Quit", key_display="q"),
    ]

    def __init__(self, session: AnySession, profile: Profile, *, link_description: str,
                 truth: str | None, report_dir: Path | None,
                 clock: Callable[[], float], replay: PacedReplay | None,
                 after: AfterTrim | None = None) -> None:
        super().__init__()
        self.session = session
        self.profile = profile
        self.link_description = link_description
        self.truth = truth
        self.report_dir = report_dir
        self.replay = replay
        self.state = LiveState(clock)
        self.result: AnyResult | None = None
        self.results: list[AnyResult] = []
        self.followup = Followup(self, profile, self.state, self.run_session, after)
        self.confirmed = False
        self._quitting = False
        self._progress: Progress | None = None
        self._dirty = False
        self._new_commands = NewCommands()

    def compose(self) -> ComposeResult:
        with Horizontal(id="main"):
            with Vertical(id="left"):
                yield LinkPanel(self.state, link_description=self.link_description,
                                vehicle=self.profile.name,
                                stale_after_s=HEARTBEAT_STALE_S)
                yield Stepper(self.profile)
                yield NextSteps()
                yield EventLog()
            with Vertical(id="right"):
                with Vertical(id="live"):
                    yield AttitudePanel(self.state)
                    yield ThrusterPanel(self.state, self.profile)
                yield VerdictPanel()
                yield ResultPanel(self.profile, truth=self.truth)
        yield Footer()

    def on_mount(self) -> None:
        self.set_interval(1 / REDRAW_HZ, self._redraw)
        self._show_pace()
        self.run_session(self.session)

    def run_session(self, session: AnySession, kind: str = "trim") -> None:
        """Run ``session`` (the trim, or later a check: ``kind`` "verify" or "float") and
        show it; the operator confirms it afresh (unless it was confirmed up front)."""
        if kind != "trim":
            self.state.restart()
            self.query_one(Stepper).restart(kind)
            link = self.query_one(LinkPanel)
            link.link_description, link.closed = session.link.description, False
        self.session, self.result, self.confirmed = session, None, False
        session.add_presenter(TuiPresenter(self, self.state))
        # a task of its own, which the worker only waits on: closing the app cancels its
        # workers, and the session must still end by the procedure's abort (releasing)
        self._session_task = task = asyncio.ensure_future(session.run())
        self.run_worker(self._wait_session(task), name="session", group="session")
        self.refresh_bindings()

    async def _wait_session(self, task: asyncio.Future[AnyResult]) -> None:
        self.post_message(SessionEnded(await asyncio.shield(task)))

    async def on_unmount(self) -> None:
        """Whatever closes the app, the session ends (and releases) before it is gone."""
        if not self._session_task.done():
            self.session.abort("the terminal UI closed")
        self.result = await self._session_task
        if self.result not in self.results:
            self.results.append(self.result)

    # ---------------------------------------------------------------- session events
    @on(TelemetryChanged)
    def _telemetry(self, message: TelemetryChanged) -> None:
        self._progress, self._dirty = message.progress, True

    def _redraw(self) -> None:
        """Apply the latest telemetry to the panels (at REDRAW_HZ: light over SSH)."""
        if not self._dirty:
            return
        try:
            attitude, thrusters = self.query_one(AttitudePanel), self.query_one(ThrusterPanel)
            stepper, link = self.query_one(Stepper), self.query_one(LinkPanel)
        except NoMatches:   # closing: the panels are gone while the timer still ticks
            return
        s, self._dirty = self.state, False
        attitude.t_s = s.attitude.t_s if s.attitude else s.t_s
        thrusters.t_s = s.thrusters.t_s if s.thrusters else s.t_s
        stepper.progress = self._progress
        link.show()

    @on(NoticeReceived)
    def _notice(self, message: NoticeReceived) -> None:
        n, self._progress = message.notice, message.progress
        self.query_one(Stepper).progress = message.progress
        log = self.query_one(EventLog)
        if n.result is not None:
            estimate, proposal = n.result.estimate, n.result.proposal
            log.add(n.t_s, "result", f"estimate: m_ext {estimate.m_ext_kg:+.3f} kg")
            self.query_one(ResultPanel).show_result(estimate, proposal)
            self.add_class("-result")
        else:
            log.add(n.t_s, n.kind, n.text)
        if n.phase is Phase.CONFIRM:
            self.bell()
            self.notify("Ready: press s to let trimd command the vehicle.", timeout=10)
        elif n.phase in (Phase.FAILED, Phase.ABORTED):
            self.bell()
        self.refresh_bindings()

    @on(LinkMessage)
    def _link_message(self, message: LinkMessage) -> None:
        self.query_one(EventLog).add(message.t_s, message.kind, message.text)

    @on(CommandSent)
    def _command(self, message: CommandSent) -> None:
        text = self._new_commands(message.command)
        if text is not None:
            self.query_one(EventLog).add(message.t_s, "command", text)

    @on(SessionEnded)
    def _ended(self, message: SessionEnded) -> None:
        r = self.result = message.result
        self.results.append(r)
        self.query_one(LinkPanel).closed = True
        where = f"; log {r.log_path}" if r.log_path else ""
        self.query_one(EventLog).add(self.state.t_s, "state",
                                     f"session ended: {r.phase.value}{where}")
        self.followup.ended(r)
        self.refresh_bindings()
        if self._quitting:
            self.exit(r)

    @on(Resize)
    def _resize(self, event: Resize) -> None:
        self.set_class(event.size.width >= ROOMY[0] and event.size.height >= ROOMY[1],
                              "-roomy")

    # ---------------------------------------------------------------- actions
    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "start":
            progress = self.query_one(Stepper).progress
            early = progress is None or progress.phase in _BEFORE_HOLDS
            # a replay confirms where the live session was confirmed (its recording says)
            return self.result is None and not self.confirmed and early and not self.replay
        if action in ("method", "view"):
            return self.query_one(ResultPanel).estimate is not None
        if action == "pace":
            return self.replay is not None and self.result is None
        if action == "apply":
            return self.followup.can_apply
        if action in ("verify", "float"):
            return self.followup.can_verify
        return True

    def action_start(self) -> None:
        """Let trimd command the vehicle (now, or as soon as the precheck passes)."""
        self.confirmed = True
        self.session.confirm()
        self.query_one(EventLog).add(self.state.t_s, "info", "confirmed by the operator")
        self.refresh_bindings()

    def action_abort(self) -> None:
        """Stop the procedure: trimd releases the vehicle at once."""
        if self.result is None:
            self.session.abort("aborted by the operator")
            self.query_one(EventLog).add(self.state.t_s, "error", "ABORT requested")
        else:  # a verify hold whose link is being opened does not start
            self.followup.cancel()

    def stop(self, reason: str) -> None:
        """End the session for ``reason`` (releasing the vehicle, closing the log), then
        quit: what a signal does (``trimd run`` installs it for SIGINT, SIGTERM, SIGHUP).
        Safe before the app is mounted (the session then aborts as it starts)."""
        if self.result is not None:
            self.exit(self.result)
        else:
            self._quitting = True
            self.session.abort(reason)

    def action_method(self, method: str = "") -> None:
        """Show the proposal of ``method`` (default: the next one)."""
        panel = self.query_one(ResultPanel)
        if method:
            panel.method = method
        else:
            panel.next_method()
        self.add_class("-result")

    def action_view(self) -> None:
        self.toggle_class("-result")

    def action_report(self) -> None:
        panel = self.query_one(ResultPanel)
        r, p = self.result, self.session.procedure
        log_path = r.log_path if r else (self.session.recorder.path
                                         if self.session.recorder else None)
        status = f"{p.phase.value}: {p.reason}" if p.reason else p.phase.value
        report = Report(self.profile.name, self.link_description, status, log_path,
                        panel.estimate, panel.proposal, self.truth,
                        list(self.query_one(EventLog).entries),
                        self.query_one(VerdictPanel).verification)
        directory = self.report_dir or (Path(log_path).parent if log_path else Path.cwd())
        stem = f"{Path(log_path).stem}-report" if log_path else f"trimd-{self.profile.name}"
        try:
            md, js = save_report(report, directory, stem)
        except OSError as exc:
            self.notify(f"could not save the report: {exc}", severity="error")
            return
        self.query_one(EventLog).add(self.state.t_s, "info", f"report saved: {md.name}")
        self.notify(f"Report saved: {md} and {js.name}")

    def action_apply(self) -> None:
        """Record the proposal shown as the ballast installed on the vehicle."""
        self.followup.apply()
        self.refresh_bindings()

    def action_verify(self) -> None:
        """Once the ballast is on: a verify hold on the same link (after confirmation)."""
        self.run_worker(self.followup.check("verify"), name="verify-open", group="verify",
                        exclusive=True)

    def action_float(self) -> None:
        """Once the ballast is on: a float check on the same link (after confirmation):
        trimd lets go of the vehicle and measures the attitude it floats at."""
        self.run_worker(self.followup.check("float"), name="float-open", group="verify",
                        exclusive=True)

    def action_pace(self, change: str) -> None:
        """Replay: ``pause`` (or resume), ``faster`` or ``slower``."""
        if self.replay is not None:
            {"pause": self.replay.toggle_pause, "faster": self.replay.faster,
             "slower": self.replay.slower}[change]()
            self._show_pace()

    def _show_pace(self) -> None:
        if self.replay is not None:
            self.query_one(LinkPanel).border_subtitle = f"replay {self.replay.label}"

    def action_help(self) -> None:
        self.push_screen(HelpScreen([b for b in self.BINDINGS if isinstance(b, Binding)
                                     and (self.replay or not b.action.startswith("pace("))]))

    async def action_quit(self) -> None:
        """Quit; while the session runs, ask first (quitting aborts it)."""
        if self.result is not None:
            self.exit(self.result)
            return

        def answered(quit_: bool | None) -> None:
            if quit_ and self.result is not None:  # it ended while the question was open
                self.exit(self.result)
            elif quit_:
                self._quitting = True
                self.action_abort()

        self.push_screen(QuitScreen(), answered)

    def get_system_commands(self, screen: Screen[object]) -> Iterable[SystemCommand]:
        yield from super().get_system_commands(screen)
        yield SystemCommand("Start / confirm", "Let trimd command the vehicle",
                            self.action_start)
        yield SystemCommand("ABORT", "Stop the procedure and release the vehicle at once",
                            self.action_abort)
        for m in METHODS:
            yield SystemCommand(f"Ballast method: {m}", f"Show the {m} proposal",
                                lambda m=m: self.action_method(m))  # type: ignore[misc]
        yield SystemCommand("Save report", "Markdown and JSON next to the session log",
                            self.action_report)
        yield SystemCommand("Help", "Keys and panels", self.action_help)


def make_app(session: AnySession, profile: Profile, *, link_description: str,
             truth: str | None = None, report_dir: Path | None = None,
             clock: Callable[[], float] = time.monotonic,
             replay: PacedReplay | None = None, after: AfterTrim | None = None) -> TrimApp:
    """The TUI over ``session`` (not started yet; the app starts it when mounted).

    ``report_dir``: where reports go (default: beside the session log, else the current
    directory). ``clock``: only for the heartbeat age shown (tests fix it; a replay passes
    its own sample time). ``replay``: the session's link when it replays a recording.
    ``after``: what follows a trim (storing results, apply, verify; :class:`AfterTrim`).
    """
    return TrimApp(session, profile, link_description=link_description, truth=truth,
                   report_dir=report_dir, clock=clock, replay=replay, after=after)
