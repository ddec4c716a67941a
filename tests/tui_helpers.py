"""Shared set-up of the TUI tests: a Session over FakeLink and a way to wait on the app."""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import AsyncIterator, Callable
from pathlib import Path

import numpy as np
import pytest
from textual.pilot import Pilot

from tests.conftest import payload_truth
from tests.fake_vehicle import FakeLink, FakeVehicle
from trimd.ballast import propose_ballast
from trimd.profile import Profile
from trimd.samples import Sample
from trimd.session import Session
from trimd.tui import TrimApp, make_app

#: The heartbeat age shown is clock() minus the clock at the last heartbeat: 0 s here.
FIXED_CLOCK = 100.0


class PausedLink(FakeLink):
    """FakeLink that goes silent (without ending) at sample time ``pause_at`` [s]."""

    def __init__(self, vehicle: FakeVehicle, *, pause_at: float) -> None:
        super().__init__(vehicle)
        self.pause_at = pause_at

    async def samples(self) -> AsyncIterator[Sample]:
        async for s in super().samples():
            if s.t_s > self.pause_at:
                await asyncio.Event().wait()
            yield s


def app_for(profile: Profile, link: FakeLink, *, confirmed: bool, tmp_path: Path | None = None
            ) -> TrimApp:
    """The TUI over a session on ``link`` with the milp proposal, as ``trimd run`` builds it."""
    session = Session(link, profile, recorder=None, presenters=[], confirmed=confirmed,
                      propose=lambda est: propose_ballast(est, profile, method="milp"))
    return make_app(session, profile, link_description="fake:10@AftSB",
                    truth="10 kg at AftSB", report_dir=tmp_path, clock=lambda: FIXED_CLOCK)


def never_times_out(profile: Profile) -> Profile:
    """``profile`` whose holds may settle for ever: a stuck vehicle keeps the session in
    a hold however fast the fake link runs while a test presses keys."""
    return dataclasses.replace(profile, procedure=dataclasses.replace(
        profile.procedure, settle_timeout_s=1e9))


def thesis_vehicle(profile: Profile, stuck_at_deg: float | None = None) -> FakeVehicle:
    """The thesis case: 10 kg at AftSB (``stuck_at_deg``: a hold beyond never settles)."""
    W, r_g = payload_truth(profile, 10.0, np.array(profile.slot("AftSB").position_m))
    return FakeVehicle(profile, W, r_g, stuck_at_deg=stuck_at_deg)


#: Wall-clock hang guard of :func:`until` [s]: not a timing requirement (nothing here is
#: timed), only a bound on how long a test that can never finish keeps a runner busy.
HANG_GUARD_S = 300.0


async def until(pilot: Pilot[object], cond: Callable[[], bool]) -> None:
    """Let the app run until ``cond()`` holds; fail only if it looks hung (HANG_GUARD_S)."""
    hung_at = time.monotonic() + HANG_GUARD_S
    while not cond():
        if time.monotonic() > hung_at:
            pytest.fail(f"hang guard: the condition did not hold within {HANG_GUARD_S:g} s "
                        "of wall clock (is the app or the session stuck?)")
        await pilot.pause(0.02)
