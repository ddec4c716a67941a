"""``trimd run`` and ``trimd demo``: the trim procedure over a link, headless or in the TUI.

Exit codes: 0 done, 1 failed or aborted, 2 usage or profile error, 3 link error
(cannot open, or lost during the procedure).
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

from drivers import open_link
from replay.recorder import TlogRecorder
from trimd.ballast import METHODS, format_proposal, proposal_to_dict, propose_ballast
from trimd.errors import ProfileError
from trimd.estimate import StaticEstimate
from trimd.headless import HeadlessPresenter
from trimd.procedure import Notice, Output, Phase, Progress
from trimd.profile import Profile, load_profile
from trimd.samples import Sample
from trimd.session import Presenter, Session, SessionResult

__all__ = ["default_record_path", "register", "run", "run_demo"]

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
        prompt = "type 'yes' to let trimd command the vehicle, anything else aborts: "
        answer = await asyncio.get_running_loop().run_in_executor(None, input, prompt)
        if answer.strip().lower() == "yes":
            self.session.confirm()
        else:
            self.session.abort("not confirmed by the operator")


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


async def _headless(args: argparse.Namespace, profile: Profile, *, truth: bool
                    ) -> tuple[SessionResult, str | None]:
    link = await open_link(args.link, profile)
    presenters: list[Presenter] = [HeadlessPresenter(
        json_lines=args.json, proposal_text=format_proposal, proposal_dict=proposal_to_dict)]
    session = _make_session(args, profile, link, presenters)
    if not args.yes:
        presenters.append(_StdinConfirm(session))
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, session.abort, f"stopped by {sig.name}")
    result = await session.run()
    return result, _truth(link, truth)


def _start(args: argparse.Namespace, *, truth: bool) -> int:
    profile = load_profile(args.profile)
    tui = not args.headless and sys.stdin.isatty() and sys.stdout.isatty()
    if not tui and not args.yes and not sys.stdin.isatty():
        raise ProfileError("headless without a terminal cannot ask for confirmation: "
                           "pass --yes to let trimd command the vehicle")
    if tui:
        from trimd.tui.app import run_tui

        link = asyncio.run(open_link(args.link, profile))
        session = _make_session(args, profile, link, [])
        result = run_tui(session, profile, link_description=args.link,
                         truth=_truth(link, truth))
        truth_text = None
    else:
        result, truth_text = asyncio.run(_headless(args, profile, truth=truth))
    if result.phase is not Phase.DONE:
        print(f"trimd: {result.phase.value}: {result.reason}", file=sys.stderr)
    if truth_text and not args.json:
        print("\n" + truth_text)
    if result.log_path:
        print(f"session log: {result.log_path}", file=sys.stderr)
    return _exit_code(result)


def run(args: argparse.Namespace) -> int:
    return _start(args, truth=False)


def run_demo(args: argparse.Namespace) -> int:
    args.yes = True
    return _start(args, truth=True)
