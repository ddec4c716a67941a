"""``trimd replay PATH``: feed a recording through the same pipeline as a live session.

* A trimd recording carries its profile; replaying it runs the same procedure over the
  recorded samples and reproduces the live estimate and proposal exactly. With a
  terminal attached (and no ``--headless`` / ``--json``) it opens the TUI, with pause
  and speed keys; the recording's own times drive the procedure at any pace.
* A foreign log (QGroundControl / MAVProxy ``.tlog``, ArduSub DataFlash ``.bin``) needs
  ``--profile``; trimd reports what the log holds and estimates from the steady attitude
  holds it finds. A log without holds ends with that statement and exit code 1.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from trimd.app.headless import HeadlessPresenter
from trimd.app.report import format_estimate, format_proposal, format_result
from trimd.app.session import Presenter, Session, SessionResult
from trimd.app.verify import verify_procedure
from trimd.ballast.propose import METHODS, propose_ballast
from trimd.cli.argtypes import bounded
from trimd.cli.inspect import HOLD_MODES, format_report, inspect_log
from trimd.cli.run import wants_tui
from trimd.core.effort import thrust_at
from trimd.core.errors import DataError, EstimationError
from trimd.core.estimate import HoldSamples, StaticEstimate, estimate_static
from trimd.core.events import Phase
from trimd.core.holdfinder import find_holds
from trimd.core.link import Link
from trimd.core.model import thrust_configuration
from trimd.core.procedure import VERIFY_DONE
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile, parse_profile
from trimd.core.samples import Attitude, Battery, Health, Sample, Thrusters
from trimd.logs.replay import (
    ReplayLink,
    recorded_profile_yaml,
    recorded_trimd_texts,
    recorded_verify_target,
)
from trimd.tui.run import run_in_tui

if TYPE_CHECKING:
    from trimd.tui import TrimApp

__all__ = ["register", "replay_app", "replay_session", "run"]


def register(sub: Any) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "replay", help="replay a recorded session or analyse a vehicle log",
        description="Replay a trimd recording through the procedure (same result as live), "
        "or find steady attitude holds in a foreign .tlog / DataFlash .bin log.")
    p.add_argument("path", help="a .tlog or DataFlash .bin file")
    p.add_argument("--profile", help="vehicle profile (a trimd recording carries its own)")
    pace = p.add_mutually_exclusive_group()
    pace.add_argument("--speed", type=bounded(0.0), help="pace at this many times real time (> 0)")
    pace.add_argument("--fast", action="store_true", help="as fast as possible (the default "
                      "headless; the TUI starts at real time)")
    p.add_argument("--headless", action="store_true", help="no terminal UI")
    p.add_argument("--json", action="store_true", help="headless, one JSON object per line")
    p.add_argument("--ballast", choices=METHODS, default="milp", help="ballast method")
    p.set_defaults(func=run)


def _profile(path: str, name: str | None) -> tuple[Profile, bool]:
    """The profile to use and whether the log is a trimd recording."""
    try:
        text = recorded_profile_yaml(path)
    except DataError as exc:  # a trimd recording whose profile block is damaged
        if not name:
            raise DataError(f"{exc}: pass --profile to replay it with that profile") from None
        print(f"trimd: warning: {exc}; replaying with --profile {name}", file=sys.stderr)
        return load_profile(name), True
    if name:
        return load_profile(name), text is not None
    if text is None:
        raise DataError(f"{path}: not a trimd recording, so it carries no profile: "
                        "pass --profile")
    return parse_profile(yaml.safe_load(text), f"{path} (recorded profile)"), True


def _session(link: Link, path: str, profile: Profile, *,
             presenters: list[Presenter], method: str) -> Session:
    """The replay's session over ``link`` (the recording ``path``): a verify hold when
    the recording carries a verify target, else the trim, proposing by ``method``;
    confirmed where the live session was (the recording's :class:`Confirmed`)."""
    target = recorded_verify_target(path)
    procedure = None if target is None else verify_procedure(
        profile, target, confirmed=False, source=f"{path} (recorded verify target)")

    def propose(estimate: StaticEstimate) -> Any:
        return propose_ballast(estimate, profile, method=method)

    return Session(link, profile, recorder=None, presenters=presenters, confirmed=False,
                   propose=propose, procedure=procedure, wall_clock=False)


async def replay_session(path: str, profile: Profile, *, speed: float | None,
                         presenters: list[Presenter], method: str
                         ) -> tuple[SessionResult, ReplayLink]:
    """Run the recorded procedure (trim or verify hold) over a recording; return its result
    and the link."""
    link = ReplayLink(path, profile, speed=speed)
    session = _session(link, path, profile, presenters=presenters, method=method)
    return await session.run(), link


def replay_app(path: str, profile: Profile, *, speed: float, method: str) -> TrimApp:
    """The TUI over a replay of ``path`` starting at ``speed`` × real time (inf: as fast
    as possible); its heartbeat age is on the recording's clock."""
    from trimd.tui import make_app
    from trimd.tui.replay_pace import PacedReplay

    link = PacedReplay(ReplayLink(path, profile), speed=speed)
    return make_app(_session(link, path, profile, presenters=[], method=method), profile,
                    link_description=link.description, replay=link, clock=lambda: link.t_s)


def _while_holding(samples: list[Sample]) -> list[Attitude]:
    """The attitude samples taken while the vehicle was armed in a mode that holds
    attitude (all of them when the log reports neither mode nor arming)."""
    state: Health | None = None
    seen = any(isinstance(s, Health) for s in samples)
    out = []
    for s in samples:
        if isinstance(s, Health):
            state = s
        elif isinstance(s, Attitude) and (not seen or (
                state is not None and state.armed and state.mode in HOLD_MODES)):
            out.append(s)
    return out


def _holds(samples: list[Sample], profile: Profile, name: str) -> list[HoldSamples]:
    """The steady holds of a log, found as the live procedure finds them; each thruster's
    thrust rides along (the thrust curves' share of the ±)."""
    att = _while_holding(samples)
    thr = [s for s in samples if isinstance(s, Thrusters)]
    if not att or not thr:
        raise DataError(f"{name}: no attitude while armed in a holding mode, or no thruster "
                        "outputs, to estimate from")
    t = np.array([s.t_s for s in thr])
    thrust, ok = thrust_at(profile, t, thr, [s for s in samples if isinstance(s, Battery)])
    tau = thrust[ok] @ thrust_configuration(profile.thrusters).T
    return find_holds(att, t[ok], tau, profile, thrust[ok])


def _analyse_foreign(path: str, profile: Profile, args: argparse.Namespace) -> int:
    print(format_report(inspect_log(path, profile)))
    samples = list(ReplayLink(path, profile).read_samples())
    try:
        holds = _holds(samples, profile, path)
        if not holds:
            raise DataError("no steady attitude hold with thruster outputs found (each needs "
                            f"{profile.procedure.min_steady_s:g} s settled, then samples to "
                            "collect)")
        est = estimate_static(holds, profile)
    except (EstimationError, DataError) as exc:
        print(f"trimd: cannot estimate from this log: {exc}", file=sys.stderr)
        return 1
    print("\n" + format_estimate(est))
    print("\n" + format_proposal(propose_ballast(est, profile, method=args.ballast)))
    return 0


def run(args: argparse.Namespace) -> int:
    path = str(args.path)
    if not Path(path).is_file():
        raise DataError(f"{path}: no such file")
    profile, recording = _profile(path, args.profile)
    if not recording:
        return _analyse_foreign(path, profile, args)
    if wants_tui(args):
        app = replay_app(path, profile, speed=math.inf if args.fast else args.speed or 1.0,
                         method=args.ballast)
        result = asyncio.run(run_in_tui(app))
        warnings = app.replay.link.warnings if app.replay else []
        text = format_result(result)
        if text:
            print(text)
    else:
        presenter = HeadlessPresenter(json_lines=args.json)
        result, link = asyncio.run(replay_session(
            path, profile, speed=args.speed, presenters=[presenter], method=args.ballast))
        warnings = link.warnings
    for warning in warnings:
        print(f"trimd: warning: {warning}", file=sys.stderr)
    if result.phase is not Phase.DONE:
        print(f"trimd: replay ended {result.phase.value}: {result.reason}", file=sys.stderr)
        if recorded_verify_target(path) is None and VERIFY_DONE in recorded_trimd_texts(path):
            print(f"trimd: {path} is a verify hold recorded by an older trimd, without the "
                  "trim it verified: it replays only as a trim, which it is not (its verdict "
                  "is in the trim history: trimd history)", file=sys.stderr)
        return 1
    return 0
