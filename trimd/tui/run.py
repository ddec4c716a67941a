"""Running a session in the terminal UI until the operator quits or a signal stops it."""

from __future__ import annotations

import asyncio
import os
import signal

from trimd.app.headless import stop_on_signals
from trimd.app.results import AnyResult
from trimd.tui.app import TrimApp

__all__ = ["run_in_tui"]


async def run_in_tui(app: TrimApp) -> AnyResult:
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
