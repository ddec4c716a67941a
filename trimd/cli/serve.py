"""``trimd serve``: the passive watch as a long-running service, with a web page and a JSON API.

``trimd serve --link URL --profile P [--port 8970] [--host 0.0.0.0] [--data DIR]`` follows
the vehicle dive after dive (:mod:`trimd.app.serve`: it reconnects, survives autopilot
reboots, records each dive and stores every segment and alert in the trim history at
``DIR/trimd.db``) and serves on one port the page for people and the JSON API
(:mod:`trimd.app.web`). ``--link`` and ``--profile`` default to ``$TRIMD_LINK`` and
``$TRIMD_PROFILE`` (the BlueOS extension sets them). It never commands the vehicle; trims
are started from the topside (``trimd run``). It runs until SIGINT, SIGTERM or SIGHUP.
Exit codes: 0 stopped, 2 usage, profile or data errors (a port in use), 3 link errors.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from pathlib import Path

from trimd.app.files import data_dir
from trimd.app.headless import stop_on_signals
from trimd.app.history import History
from trimd.app.history.calibration import calibrated_profile
from trimd.app.serve import DEFAULT_PORT, Clock, Service
from trimd.cli.argtypes import Subcommands, bounded, integer
from trimd.cli.history_args import vehicle_of
from trimd.cli.watch_args import add_watch_args, new_watch
from trimd.core.errors import UsageError
from trimd.core.profile_yaml import load_profile, read_profile_text
from trimd.core.watch import TrimWatch

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "serve", help="the watch as a service: every dive, a web page and a JSON API",
        description="Keep the passive trim watch running on the vehicle across dives "
        "(reconnecting, recording each dive, storing segments and alerts in the history) and "
        "serve a web page and a JSON API on one port. Never commands the vehicle.")
    p.add_argument("--link", default=os.environ.get("TRIMD_LINK"),
                   help="mavlink:<conn> | sim[:opts] | serial:<dev>[,baud] (default "
                   "$TRIMD_LINK)")
    p.add_argument("--profile", default=os.environ.get("TRIMD_PROFILE"),
                   help="vehicle profile, YAML path or name (default $TRIMD_PROFILE)")
    p.add_argument("--host", default="0.0.0.0", help="address to serve on (default all)")
    p.add_argument("--port", type=integer(1, 65535), default=DEFAULT_PORT,
                   help=f"HTTP port (default {DEFAULT_PORT})")
    p.add_argument("--data", metavar="DIR", help="the history (DIR/trimd.db) and the dive "
                   "recordings (DIR/dives/) (default $TRIMD_DATA_DIR, else "
                   "~/.local/share/trimd)")
    p.add_argument("--vehicle", metavar="NAME", help="the vehicle's records in the history "
                   "(default: the profile's name, with #SYSID when the link URL gives one)")
    p.add_argument("--sim-rate", type=_rate, default=1.0, metavar="R",
                   help="sim links: simulated seconds per wall second (default 1; 'max': as "
                   "fast as the machine goes)")
    add_watch_args(p)
    p.set_defaults(func=run)


def _rate(text: str) -> float | None:
    """``--sim-rate``: a positive number, or ``max`` (None: unpaced)."""
    return None if text == "max" else bounded(0.0)(text)


async def _serve(args: argparse.Namespace, service: Service) -> int:
    from aiohttp import web  # 0.5 s: only for serve

    from trimd.app.web import make_app

    stop = asyncio.Event()
    stop_on_signals(lambda why: stop.set())
    runner = web.AppRunner(make_app(service), access_log=None)
    await runner.setup()
    try:
        await web.TCPSite(runner, args.host, args.port).start()
        print(f"trimd serve: http://{args.host}:{args.port}/ (data {service.data}; passive: "
              "trimd sends the vehicle no command)", file=sys.stderr, flush=True)
        await service.run(stop)
    finally:
        await runner.cleanup()
    return 0


def run(args: argparse.Namespace) -> int:
    if not args.link or not args.profile:
        raise UsageError("give --link URL and --profile P (or set TRIMD_LINK and "
                         "TRIMD_PROFILE)", "trimd serve")
    profile = load_profile(args.profile)
    data = Path(args.data) if args.data else data_dir()
    args.db = str(data / "trimd.db")  # where --baseline last reads
    vehicle = vehicle_of(args, profile.name)
    profile = calibrated_profile(args.db, vehicle, profile)  # docs/method.md §7

    def watch(clock: Clock) -> TrimWatch:
        return new_watch(args, profile, clock)

    def log(line: str) -> None:
        print(f"trimd serve: {line}", file=sys.stderr, flush=True)

    with History(args.db) as history:
        service = Service(args.link, profile, read_profile_text(args.profile)[0], data,
                          history, vehicle, watch, rate=args.sim_rate, log=log)
        return asyncio.run(_serve(args, service))
