"""An identification experiment over a link: the excitation state machine in a session,
every sample kept for the fit."""

from __future__ import annotations

import asyncio
import signal
from typing import Never

from trimd.app.session import Recorder, Session, SessionResult
from trimd.core.events import Notice, Output, Progress
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.samples import Sample
from trimd.identify.experiment import Excite

__all__ = ["SampleCollector", "run_experiment"]


class SampleCollector:
    """A session presenter that keeps every sample (as recorded) and prints state notices."""

    def __init__(self, quiet: bool = False) -> None:
        self.samples: list[Sample] = []
        self.quiet = quiet

    def output(self, out: Output[object, object], progress: Progress) -> None:
        if isinstance(out, Notice) and not self.quiet:
            print(f"[{out.t_s:8.1f} s] {out.text}", flush=True)

    def sample(self, sample: Sample, progress: Progress) -> None:
        self.samples.append(sample)


async def run_experiment(link: Link, profile: Profile, excite: Excite, *,
                         recorder: Recorder | None = None, quiet: bool = True,
                         signals: bool = False
                         ) -> tuple[SessionResult[Never, Never], list[Sample]]:
    """Run ``excite`` over ``link`` in a :class:`Session`; the result and every sample.
    With ``signals``, SIGINT and SIGTERM abort the session (it releases the vehicle)."""
    collector = SampleCollector(quiet)
    session: Session[Never, Never] = Session(link, profile, recorder=recorder,
                                             presenters=[collector], procedure=excite)
    if signals:
        loop = asyncio.get_running_loop()
        for sig_no in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig_no, session.abort, f"stopped by {sig_no.name}")
    return await session.run(), collector.samples
