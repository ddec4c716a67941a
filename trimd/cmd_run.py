"""``trimd run`` and ``trimd demo``: the trim procedure over a link, headless or in the TUI.

Exit codes: 0 done, 1 failed or aborted, 2 usage or profile error, 3 link error
(cannot open, or lost during the procedure). SIGINT, SIGTERM and SIGHUP (an SSH session
that drops) stop the session, headless or in the TUI: trimd releases the vehicle, closes
the log and exits 1.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drivers import open_link
from replay.recorder import TlogRecorder
from trimd.argtypes import integer
from trimd.ballast import METHODS, format_proposal, proposal_to_dict, propose_ballast
from trimd.cmd_solve import format_estimate
from trimd.errors import ProfileError
from trimd.estimate import StaticEstimate
from trimd.headless import HeadlessPresenter
from trimd.procedure import Notice, Output, Phase, Progress
from trimd.profile import Profile, load_profile
from trimd.samples import Sample
from trimd.session import Presenter, Session, SessionResult

if TYPE_CHECKING:
    from trimd.tui import TrimApp

__all__ = ["STOP_SIGNALS", "default_record_path", "format_result", "register", "run",
           "run_demo", "run_in_tui", "stop_on_signals", "wants_tui"]

#: Signals that stop a session cleanly: Ctrl-C (headless), ``kill``, an SSH drop.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

DEMO_PROFILE = "sabertooth-dh2"
DEMO_LINK = "sim:payload=10@AftSB"


def register(sub: Any) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "run", help="run the trim procedure on a vehicle",
        description="Hold the vehicle level, then tilted; estimate its centre of gravity and "
        "extra mass; propose ballast. Commands the vehicle only after confirmation.")
    p.add_argument("--link", required=True, help="sim[:opts] | mavlink:<conn> | "
                   "serial:<dev>[,baud] | replay:<path>")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--sysid", type=integer(1, 255), metavar="N",
                   help="mavlink: the vehicle's system id (the URL's ?sysid=N); default: "
                   "the first autopilot that is not a ground station")
    _common(p)
    p.set_defaults(func=run)
    d: argparse.ArgumentParser = sub.add_parser(
        "demo", help="the full procedure on the simulated Sabertooth with 10 kg at AftSB",
        description="trimd run --link sim:payload=10@AftSB --profile sabertooth-dh2 --yes, "
        "ending with the simulator's truth beside the estimate.")
    _common(d)
    d.set_defaults(func=run_demo, link=DEMO_LINK, profile=DEMO_PROFILE)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--headless", action="store_true", help="no terminal UI (daemon mode)")
    p.add_argument("--yes", action="store_true", help="confirm up front: trimd may command "
                   "the vehicle without asking")
    p.add_argument("--json", action="store_true", help="headless: one JSON object per line")
    p.add_argument("--record", metavar="PATH", help="session log (default: a timestamped "
                   "file in $TRIMD_DATA_DIR or ~/.local/share/trimd/sessions)")
    p.add_argument("--no-record", action="store_true", help="do not write a session log")
    p.add_argument("--ballast", choices=METHODS, default="milp", help="ballast method")


def default_record_path(profile: Profile) -> Path:
    """``<data dir>/sessions/YYYYmmdd-HHMMSS-<profile>.tlog``."""
    base = os.environ.get("TRIMD_DATA_DIR") or os.path.join(
        os.environ.get("XDG_DATA_HOME") or os.path.expanduser("~/.local/share"), "trimd")
    stamp = time.strftime("%Y%m%d-%H%M%S")
    return Path(base) / "sessions" / f"{stamp}-{profile.name}.tlog"


class _StdinConfirm:
    """Headless confirmation at a terminal: ask once when the procedure is ready."""

    def __init__(self, session: Session) -> None:
        self.session = session

    def output(self, out: Output, progress: Progress) -> None:
        if isinstance(out, Notice) and out.data is Phase.CONFIRM:
            asyncio.get_running_loop().create_task(self._ask())

    def sample(self, sample: Sample, progress: Progress) -> None:
        return None

    async def _ask(self) -> None:
        print("type 'yes' to let trimd command the vehicle, anything else aborts: ",
              end="", flush=True)
        answer = await _read_line(sys.stdin.fileno())
        if answer.strip().lower() == "yes":
            self.session.confirm()
        else:
            self.session.abort("not confirmed by the operator")


async def _read_line(fd: int) -> str:
    """One line from ``fd`` ("" at end of file) without a thread: a blocked ``input()``
    in an executor would keep the process alive after a signal ended the session."""
    loop = asyncio.get_running_loop()
    line: asyncio.Future[str] = loop.create_future()
    buffer = bytearray()

    def readable() -> None:
        chunk = os.read(fd, 1024)
        buffer.extend(chunk)
        if (not chunk or b"\n" in chunk) and not line.done():
            line.set_result(buffer.split(b"\n", 1)[0].decode(errors="replace"))

    loop.add_reader(fd, readable)
    try:
        return await line
    finally:
        loop.remove_reader(fd)


def _exit_code(result: SessionResult) -> int:
    if result.phase is Phase.DONE:
        return 0
    return 3 if result.cause == "link" else 1


def _make_session(args: argparse.Namespace, profile: Profile, link: Any,
                  presenters: list[Presenter]) -> Session:
    recorder = None
    if not args.no_record:
        path = Path(args.record) if args.record else default_record_path(profile)
        recorder = TlogRecorder(path, profile, Path(profile.source).read_text(encoding="utf-8"))

    def propose(estimate: StaticEstimate) -> Any:
        return propose_ballast(estimate, profile, method=args.ballast)

    return Session(link, profile, recorder=recorder, presenters=presenters,
                   confirmed=args.yes, propose=propose)


def _truth(link: Any, wanted: bool) -> str | None:
    return str(link.truth()) if wanted and hasattr(link, "truth") else None


def stop_on_signals(stop: Callable[[str], None]) -> None:
    """On any of :data:`STOP_SIGNALS`, call ``stop("stopped by SIGTERM")`` (etc.) on the
    running loop: ``Session.abort`` headless, ``TrimApp.stop`` in the TUI. Either way the
    session releases the vehicle and closes the log before the process exits."""
    loop = asyncio.get_running_loop()
    for sig in STOP_SIGNALS:
        loop.add_signal_handler(sig, stop, f"stopped by {sig.name}")


def wants_tui(args: argparse.Namespace) -> bool:
    """The TUI, unless ``--headless`` or ``--json`` or no terminal is attached."""
    return not args.headless and not args.json and sys.stdin.isatty() and sys.stdout.isatty()


async def run_in_tui(app: TrimApp) -> SessionResult:
    """Run ``app`` until the operator quits or a signal stops it; how the session ended.

    The session always ends (and releases the vehicle) before this returns. On SIGHUP
    the terminal is gone (an SSH drop): once the session has ended, the process exits
    with code 1 without waiting for Textual, which would block for ever restoring a
    terminal that no longer exists.
    """
    stop_on_signals(app.stop)
    leaving: set[asyncio.Future[None]] = set()  # asyncio keeps only weak references
    asyncio.get_running_loop().add_signal_handler(signal.SIGHUP, _hang_up, app, leaving)
    await app.run_async()
    if app.result is None:
        raise RuntimeError("the terminal UI stopped before the session ended")
    return app.result


def _hang_up(app: TrimApp, leaving: set[asyncio.Future[None]]) -> None:
    """SIGHUP in the TUI: stop as for any signal, then leave once the session has ended
    (vehicle released, log closed): there is no terminal left to restore."""
    app.stop("stopped by SIGHUP")

    async def leave() -> None:
        while app.result is None:
            await asyncio.sleep(0.05)
        os._exit(1)

    leaving.add(asyncio.ensure_future(leave()))


def format_result(result: SessionResult) -> str | None:
    """The estimate and proposal as the headless daemon prints them (None: no estimate)."""
    if result.estimate is None:
        return None
    text = format_estimate(result.estimate)
    return text + "\n\n" + format_proposal(result.proposal) if result.proposal else text


async def _headless(args: argparse.Namespace, profile: Profile, *, truth: bool
                    ) -> tuple[SessionResult, str | None]:
    link = await open_link(args.link, profile)
    presenters: list[Presenter] = [HeadlessPresenter(
        json_lines=args.json, proposal_text=format_proposal, proposal_dict=proposal_to_dict)]
    session = _make_session(args, profile, link, presenters)
    if not args.yes:
        presenters.append(_StdinConfirm(session))
    stop_on_signals(session.abort)
    result = await session.run()
    return result, _truth(link, truth)


async def _tui(args: argparse.Namespace, profile: Profile, *, truth: bool
               ) -> tuple[SessionResult, str | None]:
    from trimd.tui import make_app

    link = await open_link(args.link, profile)
    truth_text = _truth(link, truth)
    app = make_app(_make_session(args, profile, link, []), profile,
                   link_description=link.description, truth=truth_text)
    return await run_in_tui(app), truth_text


def _start(args: argparse.Namespace, *, truth: bool) -> int:
    profile = load_profile(args.profile)
    tui = wants_tui(args)
    if not tui and not args.yes and not sys.stdin.isatty():
        raise ProfileError("headless without a terminal cannot ask for confirmation: "
                           "pass --yes to let trimd command the vehicle")
    result, truth_text = asyncio.run((_tui if tui else _headless)(args, profile, truth=truth))
    if result.phase is not Phase.DONE:
        print(f"trimd: {result.phase.value}: {result.reason}", file=sys.stderr)
    text = format_result(result) if tui else None  # headless printed it as it came
    if text:
        print(text)
    if truth_text and not args.json:
        print("\n" + truth_text)
    if result.log_path:
        print(f"session log: {result.log_path}", file=sys.stderr)
    return _exit_code(result)


def run(args: argparse.Namespace) -> int:
    if args.sysid is not None:
        scheme, _, rest = args.link.partition(":")
        if scheme != "mavlink" or "sysid=" in rest:
            print("trimd run: --sysid is for a mavlink: link without ?sysid= in its URL",
                  file=sys.stderr)
            return 2
        args.link += f"{'&' if '?' in rest else '?'}sysid={args.sysid}"
    return _start(args, truth=False)


def run_demo(args: argparse.Namespace) -> int:
    args.yes = True
    return _start(args, truth=True)
