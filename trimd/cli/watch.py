"""``trimd watch``: the passive trim watch, live over a link or post-dive over logs.

* ``trimd watch --link URL --profile P [--headless] [--json]`` reads the vehicle and
  sends it nothing (with a terminal: the watch's terminal UI, a plot of W − B and the log
  of segments and alerts) (no set-point, no mode change, no MANUAL_CONTROL; no confirmation is
  needed). It runs until stopped (SIGINT, SIGTERM, SIGHUP) or ``--duration`` seconds of
  sample time.
* ``trimd watch LOG… --profile P [--plot FILE] [--json]`` reads each log (any log
  ``trimd replay`` reads) on its own.

Output: a line per steady segment and per alert, then the verdict; ``--json``: one JSON
object per line (``type`` segment, alert or verdict). Exit codes: 0 a verdict with
segments, 1 no steady segment, 2 usage or profile error, 3 link error.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

from trimd.app.connect import open_link, parse_link_url
from trimd.app.headless import stop_on_signals
from trimd.app.history import History
from trimd.app.history.calibration import calibrated_profile
from trimd.app.jsonlines import print_json
from trimd.app.watch import (
    Record,
    format_record,
    verdict,
    watch_link,
    watch_log,
    write_watch_plot,
)
from trimd.cli.argtypes import Subcommands, bounded, wants_tui
from trimd.cli.history_args import add_history_args, db_path, vehicle_of
from trimd.cli.watch_args import add_watch_args, new_watch
from trimd.core.errors import DataError, LinkError, UsageError
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.watch import TrimWatch, WatchAlert

__all__ = ["register", "run"]


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "watch", help="watch the trim passively during ordinary operation",
        description="Find the steady segments of ordinary operation (depth held, attitude "
        "and thruster effort steady, not turning or translating), estimate W − B and the "
        "net moments of each, and alert when they change. Never commands the vehicle.")
    p.add_argument("logs", nargs="*", metavar="LOG", help="post-dive: .tlog or DataFlash "
                   ".bin logs, each watched on its own")
    p.add_argument("--link", help="live: sim[:opts] | mavlink:<conn> | serial:<dev>[,baud]")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--headless", action="store_true", help="live: no terminal UI (lines "
                   "for people, or --json)")
    p.add_argument("--json", action="store_true", help="one JSON object per line")
    p.add_argument("--plot", metavar="FILE", help="PNG of W − B and the moments over time "
                   "(with several logs: FILE-1.png, FILE-2.png, …)")
    p.add_argument("--duration", type=bounded(0.0), metavar="S",
                   help="live: stop after S seconds of sample time")
    p.add_argument("--no-history", action="store_true", help="do not store the segments and "
                   "alerts in the trim history")
    add_history_args(p)
    add_watch_args(p)
    p.set_defaults(func=run)


class _Store:
    """Stores watch records in the trim history as they come, each in its own
    transaction (``--no-history``: nothing); a file that cannot take them is one warning,
    and the watch goes on."""

    def __init__(self, args: argparse.Namespace, profile: Profile) -> None:
        self.vehicle = vehicle_of(args, profile.name)
        self.history = None if args.no_history else History(db_path(args))

    def __call__(self, r: Record) -> None:
        if self.history is None:
            return
        try:
            self.history.record_watch(self.vehicle, time.time(), r.to_dict())
        except DataError as exc:
            print(f"trimd: warning: the watch is not stored in the history: {exc}",
                  file=sys.stderr)
            self.close()

    def close(self) -> None:
        if self.history is not None:
            self.history.close()
            self.history = None


def _emitter(as_json: bool, store: _Store) -> Callable[[Record], None]:
    def emit(r: Record) -> None:
        if as_json:
            print_json(r.to_dict())
        else:
            print(format_record(r), flush=True)
        store(r)
    return emit


def _finish(watch: TrimWatch, args: argparse.Namespace, source: str,
            plot: str | None) -> int:
    text = verdict(watch)
    if args.json:
        print_json({"type": "verdict", "source": source, "vehicle": watch.vehicle,
                    "segments": len(watch.segments), "alerts": len(watch.alerts),
                    "rejected": watch.rejected, "breaks": watch.breaks, "h_sigma": watch.h,
                    "baseline_dropped": watch.baseline_dropped,
                    "text": text})
    else:
        print(f"{source}: {text}")
    if plot:
        print(f"plot: {write_watch_plot(watch, plot)}", file=sys.stderr)
    return 0 if watch.segments else 1


def _wall_clock() -> Callable[[float], str]:
    """Times of a MAVLink link (``time.monotonic()``) as UTC wall-clock time."""
    offset = time.time() - time.monotonic()
    return lambda t_s: datetime.fromtimestamp(offset + t_s, UTC).strftime("%H:%M:%S UTC")


async def _live(args: argparse.Namespace, profile: Profile, tui: bool, store: _Store) -> int:
    scheme, rest = parse_link_url(args.link)
    if scheme == "replay":
        raise LinkError("trimd watch reads logs directly: trimd watch LOG --profile P")
    if scheme == "mavlink" and "pilot=always" in rest:
        raise LinkError("trimd watch sends no MANUAL_CONTROL: drop pilot=always from the URL")
    link = await open_link(args.link, profile)
    watch = new_watch(args, profile, _wall_clock() if scheme == "mavlink" else None)
    if tui:
        from trimd.tui.watch_app import WatchApp

        app = WatchApp(link, watch, until_s=args.duration)
        stop_on_signals(lambda why: app.exit())
        await app.run_async()
        await link.close()
        for r in app.records:
            store(r)
            if isinstance(r, WatchAlert):
                print(format_record(r))
        return _finish(watch, args, link.description, args.plot)
    stop = asyncio.Event()
    stop_on_signals(lambda why: stop.set())
    print(f"watching {link.description} (passive: trimd sends no command)", file=sys.stderr)
    try:
        await watch_link(link, watch, _emitter(args.json, store), until_s=args.duration,
                         stop=stop)
    finally:
        await link.close()
    return _finish(watch, args, link.description, args.plot)


def _plot_path(plot: str | None, k: int, n: int) -> str | None:
    if plot is None or n == 1:
        return plot
    p = Path(plot)
    return str(p.with_name(f"{p.stem}-{k + 1}{p.suffix or '.png'}"))


def run(args: argparse.Namespace) -> int:
    if bool(args.logs) == bool(args.link):
        raise UsageError("give either --link URL (live) or LOG files (post-dive)",
                         "trimd watch")
    profile = load_profile(args.profile)
    if not args.no_history:  # the vehicle's thrust-map calibration (docs/method.md §7)
        profile = calibrated_profile(db_path(args), vehicle_of(args, profile.name), profile)
    store = _Store(args, profile)
    try:
        if args.link:
            return asyncio.run(_live(args, profile, wants_tui(args), store))
        code = 0
        for k, path in enumerate(args.logs):
            if not Path(path).is_file():
                raise DataError(f"{path}: no such file")
            watch = new_watch(args, profile)
            for warning in watch_log(path, profile, watch, _emitter(args.json, store)):
                print(f"trimd: warning: {warning}", file=sys.stderr)
            code = max(code, _finish(watch, args, path,
                                     _plot_path(args.plot, k, len(args.logs))))
        return code
    finally:
        store.close()
