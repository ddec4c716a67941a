"""``trimd run`` and ``trimd demo``: the trim procedure over a link, headless or in the TUI.

Exit codes: 0 done, 1 failed or aborted, 2 usage or profile error, 3 link error
(cannot open, or lost during the procedure). SIGINT, SIGTERM and SIGHUP (an SSH session
that drops) stop the session, headless or in the TUI: trimd releases the vehicle, closes
the log and exits 1.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import sys
import time
from pathlib import Path

from trimd.app import connect
from trimd.app.after_trim import AfterTrim
from trimd.app.files import (
    default_record_path,
)
from trimd.app.headless import HeadlessPresenter, StdinConfirm, stop_on_signals
from trimd.app.history.calibration import calibrated_profile
from trimd.app.history.installed import current_installed
from trimd.app.jsonlines import print_result
from trimd.app.report import format_correction, format_result, undecided_advice
from trimd.app.results import AnyPresenter, AnyResult
from trimd.app.session import Session
from trimd.app.trim import TrimRequest, trim_session
from trimd.app.verify import VerifyTarget, trim_target
from trimd.ballast.correct import Correction, correction_to_dict
from trimd.ballast.proposal import Proposal
from trimd.ballast.propose import METHODS
from trimd.ballast.verify import Verification
from trimd.cli.argtypes import Subcommands, integer, wants_tui
from trimd.cli.history_args import add_history_args, db_path, vehicle_of
from trimd.core.errors import DataError, ProfileError, TrimdError, UsageError
from trimd.core.events import Phase
from trimd.core.link import Link, Truthful
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile, read_profile_text
from trimd.core.types import JsonObject
from trimd.logs.recorder import TlogRecorder

__all__ = ["register", "run", "run_demo"]

#: ``--verify`` without a file: the vehicle's last trim in the history.
LAST_TRIM = "<last trim>"


DEMO_PROFILE = "sabertooth-dh2"
DEMO_LINK = "sim:payload=10@AftSB"


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "run", help="run the trim procedure on a vehicle",
        description="Hold the vehicle level, then tilted; estimate its centre of gravity and "
        "extra mass; propose ballast. Commands the vehicle only after confirmation.")
    p.add_argument("--link", required=True, help="sim[:opts] | mavlink:<conn> | "
                   "serial:<dev>[,baud] | replay:<path>")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--verify", metavar="TRIM.json", nargs="?", const=LAST_TRIM,
                   help="after installing the ballast of a trim (its trimd run --json output "
                   "or report; alone: the vehicle's last trim in the history): one level "
                   "hold that measures what the ballast left and compares it with the "
                   "proposal's prediction")
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
    p.add_argument("--no-history", action="store_true", help="do not read the installed "
                   "ballast from the trim history (the profile's is used) nor store the "
                   "result in it")
    add_history_args(p)


def _exit_code(result: AnyResult) -> int:
    if result.phase is Phase.DONE:
        return 0
    return 3 if result.cause == "link" else 1


def _make_session(args: argparse.Namespace, profile: Profile, link: Link,
                  presenters: list[AnyPresenter]) -> Session[Proposal, Verification]:
    """The trim's session, or with ``--verify`` the verify hold of ``args.target``."""
    record = None
    if not args.no_record:
        record = Path(args.record) if args.record else default_record_path(profile)
    return trim_session(link, profile, presenters, TrimRequest(
        profile_ref=args.profile, confirmed=args.yes, ballast_method=args.ballast,
        record=record, target=args.target,
        target_source=None if args.target is None else _target_source(args)))


def _target_source(args: argparse.Namespace) -> str:
    return "the vehicle's last trim" if args.verify == LAST_TRIM else str(args.verify)


def _trim_to_verify(args: argparse.Namespace, profile: Profile) -> VerifyTarget:
    """The verify target of ``--verify FILE`` or (``--verify`` alone) of the vehicle's
    last trim in the history (:func:`trimd.app.verify.trim_target`)."""
    return trim_target(None if args.verify == LAST_TRIM else args.verify, profile,
                       db_path(args), vehicle_of(args, profile.name))


def _truth(link: Link, wanted: bool) -> str | None:
    return str(link.truth()) if wanted and isinstance(link, Truthful) else None


async def _headless(args: argparse.Namespace, profile: Profile, *, truth: bool
                    ) -> tuple[AnyResult, str | None]:
    link = await connect.open_link(args.link, profile)
    presenters: list[AnyPresenter] = [HeadlessPresenter(json_lines=args.json)]
    session = _make_session(args, profile, link, presenters)
    if not args.yes:
        session.add_presenter(StdinConfirm(session))
    stop_on_signals(session.abort)
    result = await session.run()
    return result, _truth(link, truth)


async def _tui(args: argparse.Namespace, profile: Profile, *, truth: bool
               ) -> tuple[list[AnyResult], str | None]:
    from trimd.tui import make_app
    from trimd.tui.run import run_in_tui

    link = await connect.open_link(args.link, profile)
    truth_text = _truth(link, truth)
    app = make_app(_make_session(args, profile, link, []), profile,
                   link_description=link.description, truth=truth_text,
                   after=_after_trim(args, profile))
    await run_in_tui(app)
    return app.results, truth_text


def _after_trim(args: argparse.Namespace, profile: Profile) -> AfterTrim:
    """Where results go, and how a verify hold or a float check after the trim opens its
    link (the same URL) and records (a new log: ``--record PATH`` gets ``-verify-HHMMSS``
    or ``-float-HHMMSS`` in its name)."""
    yaml_text = read_profile_text(args.profile)[0]

    def recorder(kind: str, block: JsonObject) -> TlogRecorder | None:
        if args.no_record:
            return None
        path = default_record_path(profile) if not args.record else Path(args.record)
        if args.record:
            path = path.with_name(f"{path.stem}-{kind}-{time.strftime('%H%M%S')}"
                                  f"{path.suffix}")
        if kind == "float":
            return TlogRecorder(path, profile, yaml_text, float_check=block)
        return TlogRecorder(path, profile, yaml_text, verify_target=block)

    return AfterTrim(None if args.no_history else Path(db_path(args)),
                     vehicle_of(args, profile.name), profile, args.yes,
                     lambda: connect.open_link(args.link, profile), recorder)


def _start(args: argparse.Namespace, *, truth: bool) -> int:
    profile = load_profile(args.profile)
    if not args.no_history:  # proposals (here and in the TUI) start from what is installed
        vehicle = vehicle_of(args, profile.name)
        installed, _ = current_installed(db_path(args), vehicle, profile)
        profile = calibrated_profile(db_path(args), vehicle,
                                     dataclasses.replace(profile, installed=installed))
    tui = wants_tui(args)
    if not tui and not args.yes and not sys.stdin.isatty():
        raise ProfileError("headless without a terminal cannot ask for confirmation: "
                           "pass --yes to let trimd command the vehicle")
    # what --verify checks is read before the link opens: bad input commands nothing
    args.target = _trim_to_verify(args, profile) if getattr(args, "verify", None) else None
    if tui:  # the TUI stores each session's result in the history as it ends
        results, truth_text = asyncio.run(_tui(args, profile, truth=truth))
    else:
        result, truth_text = asyncio.run(_headless(args, profile, truth=truth))
        results = [result]
    for result in results:
        if result.phase is not Phase.DONE:
            print(f"trimd: {result.phase.value}: {result.reason}", file=sys.stderr)
        text = format_result(result) if tui else None  # headless printed it as it came
        if text:
            print(text)
        if result.log_path:
            print(f"session log: {result.log_path}", file=sys.stderr)
    after = None if tui else _after_trim(args, profile)
    correction = None if after is None else _correction(args, after, results[-1])
    if truth_text:
        print_result(args.json, {"type": "truth", "text": truth_text}, "\n" + truth_text)
    if after is not None:
        _store(after, results[-1], correction)
    return _exit_code(results[-1])


def _correction(args: argparse.Namespace, after: AfterTrim, result: AnyResult
                ) -> Correction | None:
    """After a verify hold: its correction (:meth:`AfterTrim.correct`) printed, or that
    none is needed; None for a trim, or (with a warning) when it cannot be proposed. A
    hold that found the vehicle level but cannot tell gets a note of what to do."""
    if not isinstance(result.verification, Verification) or args.target is None:
        return None
    advice = undecided_advice(result.verification)
    if advice:
        print(f"trimd: note: {advice}", file=sys.stderr)
    try:
        correction = after.correct(result.verification, args.target)
    except TrimdError as exc:
        print(f"trimd: warning: no correction proposed: {exc}", file=sys.stderr)
        return None
    print_result(args.json, {"type": "correction", **correction_to_dict(correction)},
                 "\n" + format_correction(correction))
    return correction


def _store(after: AfterTrim, result: AnyResult, correction: Correction | None = None
           ) -> None:
    """Store the result (a verify hold's with its ``correction``) in the trim history; a
    file that cannot take it is a warning (the session itself succeeded and was
    printed)."""
    try:
        stored = after.store(result, correction)
    except DataError as exc:
        print(f"trimd: warning: the trim was not stored in the history: {exc}",
              file=sys.stderr)
        return
    if stored:
        print(stored, file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    if args.sysid is not None:
        scheme, _, rest = args.link.partition(":")
        if scheme != "mavlink" or "sysid=" in rest:
            raise UsageError("--sysid is for a mavlink: link without ?sysid= in its URL",
                             "trimd run")
        args.link += f"{'&' if '?' in rest else '?'}sysid={args.sysid}"
    return _start(args, truth=False)


def run_demo(args: argparse.Namespace) -> int:
    args.yes = True
    return _start(args, truth=True)
