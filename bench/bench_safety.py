"""How fast the live session releases the vehicle when its link falls silent mid-hold.

The simulated vehicle (in-process, Sabertooth, 10 kg at AftSB) is trimmed by a real
:class:`~trimd.app.session.Session`; at a set simulated time its link stops delivering
(as a cable that is cut: nothing more arrives, nothing fails). The figure is the release
command's stamp as recorded (session time: the samples' clock, advanced by the wall clock
while the link is quiet) minus the last sample's, over several cuts; beside it the
profile's ``link_timeout_s`` and the session's tick period, whose sum bounds it.
"""

from __future__ import annotations

import asyncio
import statistics
from collections.abc import AsyncIterator

from bench.size import size
from trimd.app.session import TICK_S, Session
from trimd.core.events import Notice
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Command, Release, Sample
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle

#: simulated times of the cuts, during the holds (the first alone in a tiny run)
CUTS_S = size((25.0, 31.0, 37.3, 44.9, 52.1), (25.0,))


class CutLink(SimLink):
    """The simulated vehicle whose link goes silent at ``cut_s`` of simulated time."""

    def __init__(self, vehicle: SimVehicle, cut_s: float) -> None:
        super().__init__(vehicle)
        self.cut_s = cut_s

    async def samples(self) -> AsyncIterator[Sample]:
        async for sample in super().samples():
            if sample.t_s >= self.cut_s:
                await asyncio.Event().wait()   # silent until the session closes us
            yield sample


class Stamps:
    """A recorder that keeps the last sample's and the release's session times."""

    path = "memory"

    def __init__(self) -> None:
        self.last_sample = 0.0
        self.release = float("nan")

    def sample(self, sample: Sample) -> Sample:
        self.last_sample = sample.t_s
        return sample

    def raw(self, t_s: float, packet: bytes) -> None:
        return None

    def command(self, t_s: float, command: Command) -> None:
        if isinstance(command, Release):
            self.release = t_s

    def notice(self, notice: Notice) -> None:
        return None

    def flush_due(self) -> None:
        return None

    def close(self) -> None:
        return None


def release_latency(cut_s: float) -> tuple[float, str]:
    """Release stamp minus the last sample's [s, session time], and the reason given."""
    profile = load_profile("sabertooth-dh2")
    link = CutLink(SimVehicle(profile, SimConfig(payload="10@AftSB", seed=3)), cut_s)
    stamps = Stamps()
    session = Session(link, profile, recorder=stamps, presenters=[], confirmed=True)
    result = asyncio.run(session.run())
    return stamps.release - stamps.last_sample, result.reason


def main() -> None:
    timeout = load_profile("sabertooth-dh2").procedure.link_timeout_s
    runs = [release_latency(cut) for cut in CUTS_S]
    latency = [dt for dt, _ in runs]
    print(f"release after the link fell silent mid-hold ({len(runs)} cuts): "
          f"min {min(latency):.3f} s, median {statistics.median(latency):.3f} s, max "
          f"{max(latency):.3f} s of session time after the last sample; link_timeout_s "
          f"{timeout:g} s + tick {TICK_S:g} s = {timeout + TICK_S:.1f} s bound; "
          f"reason: {runs[-1][1]!r}")
