"""The trim session: ``trimd demo`` headless, and replay throughput of a one-hour recording.

* Demo: the whole procedure on the simulated Sabertooth (10 kg at AftSB), recorded, as
  ``trimd demo --headless`` runs it; wall time beside the simulated time it covers.
* Replay: a one-hour recording of the simulated BlueROV2 Heavy (written by the session
  recorder, ~40 samples/s) read back into typed samples by trimd's replay link, beside a
  bare ``mavutil.mavlink_connection(path).recv_msg()`` loop over the same file.
"""

from __future__ import annotations

import asyncio
import tempfile
import time
from pathlib import Path

from pymavlink import mavutil

from bench.size import size
from bench.timing import best_time
from trimd.app.connect import open_link
from trimd.app.session import Session
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile, read_profile_text
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle
from trimd.logs.recorder import TlogRecorder
from trimd.logs.replay import ReplayLink

HOUR_S = size(3600.0, 60.0)   # "one hour": a minute in a tiny run


def demo(tmp: Path) -> tuple[float, float]:
    """Wall time [s] and simulated time [s] of the demo session."""
    profile = load_profile("sabertooth-dh2")
    text = read_profile_text("sabertooth-dh2")[0]

    async def go() -> float:
        link = await open_link("sim:payload=10@AftSB", profile)
        session = Session(link, profile, recorder=TlogRecorder(tmp / "demo.tlog", profile, text),
                          presenters=[], confirmed=True)
        result = await session.run()
        assert result.estimate is not None, result.reason
        return session.procedure.progress.t_s

    t0 = time.perf_counter()
    simulated = asyncio.run(go())
    return time.perf_counter() - t0, simulated


def record_hour(profile: Profile, path: Path) -> int:
    """One hour of the simulated vehicle holding level, recorded as a session would."""
    link = SimLink(SimVehicle(profile, SimConfig(payload="0.3@W-aft-ctr", dvl=True)))
    recorder = TlogRecorder(path, profile, read_profile_text(profile.name)[0])

    async def go() -> int:
        n = 0
        async for sample in link.samples():
            recorder.sample(sample)
            n += 1
            if sample.t_s >= HOUR_S:
                break
        return n

    n = asyncio.run(go())
    recorder.close()
    return n


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        wall, simulated = demo(tmp)
        print(f"trimd demo headless: {wall:.2f} s wall for {simulated:.0f} s simulated "
              f"({simulated / wall:.0f}× real time)")
        profile = load_profile("bluerov2-heavy")
        path = tmp / "hour.tlog"
        written = record_hour(profile, path)
        counts = {"samples": 0, "messages": 0}

        def replay() -> None:
            counts["samples"] = sum(1 for _ in ReplayLink(path, profile).read_samples())

        def bare() -> None:
            mav = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
            n = 0
            while mav.recv_msg() is not None:
                n += 1
            counts["messages"] = n

        t_replay = best_time(replay, repeat=2)
        t_bare = best_time(bare, repeat=2)
        print(f"replay of a one-hour recording ({written} samples written, "
              f"{counts['samples']} read back): {counts['samples'] / t_replay:,.0f} samples/s; "
              f"bare pymavlink recv_msg over the same file ({counts['messages']} messages): "
              f"{counts['messages'] / t_bare:,.0f} messages/s; time ratio "
              f"pymavlink/trimd {t_bare / t_replay:.2f}")


if __name__ == "__main__":
    main()
