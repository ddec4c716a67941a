"""Shared set-up of the TUI tests: a Session over FakeLink or the in-process simulated
vehicle (recording what it was sent) and a way to wait on the app."""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from textual.pilot import Pilot

from tests.helpers import FakeLink, FakeVehicle, payload_truth
from trimd.app.connect import open_link
from trimd.app.session import Session
from trimd.ballast.propose import propose_ballast
from trimd.core.profile import Profile
from trimd.core.samples import Command, Sample
from trimd.drivers.sim.link import SimLink
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


class RecordingSimLink(SimLink):
    """The in-process simulated vehicle (a ``sim:`` link) keeping, as FakeLink does, the
    commands that reached it: ``sent`` in order, ``commands`` with the simulated time [s]
    each was applied at (both after the vehicle took it).

    ``pause_when(link)``, asked before each sample is handed over, freezes the simulation
    for good once true (the stream goes silent without ending, as PausedLink;
    ``paused_at``: the simulated time it froze at): the vehicle stays mid-manoeuvre while
    a test presses keys, however slowly the runner goes, and still takes commands.
    ``hold_while(link)`` holds the next sample back for as long as it is true (e.g. while
    the procedure waits for the operator: the confirmation then comes after the same
    sample however long the key press takes).
    """

    def __init__(self, link: SimLink, *,
                 pause_when: Callable[[RecordingSimLink], bool] | None = None,
                 hold_while: Callable[[RecordingSimLink], bool] | None = None) -> None:
        super().__init__(link.vehicle)
        self.description = link.description
        self.sent: list[Command] = []
        self.commands: list[tuple[float, Command]] = []
        self.pause_when = pause_when
        self.hold_while = hold_while
        self.paused_at: float | None = None

    async def samples(self) -> AsyncIterator[Sample]:
        async for s in super().samples():
            if self.paused_at is None and self.pause_when is not None and self.pause_when(self):
                self.paused_at = self.vehicle.t_s
                await asyncio.Event().wait()
            while self.hold_while is not None and self.hold_while(self):
                await asyncio.sleep(0.005)
            yield s

    async def send(self, command: Command) -> None:
        await super().send(command)
        self.sent.append(command)
        self.commands.append((self.vehicle.t_s, command))


async def recording_sim_link(options: str, profile: Profile, *,
                             pause_when: Callable[[RecordingSimLink], bool] | None = None,
                             hold_while: Callable[[RecordingSimLink], bool] | None = None
                             ) -> RecordingSimLink:
    """The simulated vehicle of ``sim:options``, opened as ``trimd run --link`` opens it,
    recording what it is sent (see :class:`RecordingSimLink`)."""
    link = await open_link(f"sim:{options}", profile)
    assert isinstance(link, SimLink), link
    return RecordingSimLink(link, pause_when=pause_when, hold_while=hold_while)


def app_for(profile: Profile, link: Any, *, confirmed: bool, tmp_path: Path | None = None,
            link_description: str = "fake:10@AftSB", truth: str | None = "10 kg at AftSB"
            ) -> TrimApp:
    """The TUI over a session on ``link`` with the milp proposal, as ``trimd run`` builds it."""
    session = Session(link, profile, recorder=None, presenters=[], confirmed=confirmed,
                      propose=lambda est: propose_ballast(est, profile, method="milp"))
    return make_app(session, profile, link_description=link_description,
                    truth=truth, report_dir=tmp_path, clock=lambda: FIXED_CLOCK)


def never_times_out(profile: Profile) -> Profile:
    """``profile`` whose holds may settle for ever: a stuck vehicle keeps the session in
    a hold however fast the fake link runs while a test presses keys."""
    return dataclasses.replace(profile, procedure=dataclasses.replace(
        profile.procedure, settle_timeout_s=1e9))


def never_gives_up(profile: Profile) -> Profile:
    """:func:`never_times_out`, and a link may fall silent for ever (RecordingSimLink's
    pause) without the session failing on it while a test presses keys."""
    patient = never_times_out(profile)
    return dataclasses.replace(patient, procedure=dataclasses.replace(
        patient.procedure, link_timeout_s=1e9))


def thesis_vehicle(profile: Profile, stuck_at_deg: float | None = None) -> FakeVehicle:
    """The thesis case: 10 kg at AftSB (``stuck_at_deg``: a hold beyond never settles)."""
    W, r_g = payload_truth(profile, 10.0, np.array(profile.slot("AftSB").position_m))
    return FakeVehicle(profile, W, r_g, stuck_at_deg=stuck_at_deg)


#: Wall-clock hang guard of :func:`until` [s]: not a timing requirement (nothing here is
#: timed), only a bound on how long a test that can never finish keeps a runner busy.
HANG_GUARD_S = 300.0


async def until(pilot: Pilot[object], cond: Callable[[], bool]) -> None:
    """Let the app run until ``cond()`` holds, then let its screen catch up; fail only if
    it looks hung (HANG_GUARD_S). Polled by sleeping, not by ``pilot.pause``: each pause
    messages every widget and renders the screen, work that grows with the wall time a
    test waits."""
    hung_at = time.monotonic() + HANG_GUARD_S
    while not cond():
        if time.monotonic() > hung_at:
            pytest.fail(f"hang guard: the condition did not hold within {HANG_GUARD_S:g} s "
                        "of wall clock (is the app or the session stuck?)")
        await asyncio.sleep(0.05)
    await pilot.pause()
