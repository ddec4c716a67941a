"""trimd beside a pilot's ground station (issue 13): never impersonate the pilot, yield at
once when the pilot takes over.

The simulated ArduSub is served on two endpoints behind one router (as BlueOS does): trimd
on one, a pymavlink ground station with QGroundControl's ids (255/190) on the other. The
router passes each station's packets to the other, so the pilot's station sees exactly
what trimd sends. Wall-clock limits only keep a broken link from hanging the suite;
moments are taken where they happen (the vehicle's time when the server handles a
request, the order in which the pilot's station received messages), never from when a
busy test thread got round to look.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.drivers.test_mavlink_link import (
    TRIMD,
    WALL_LIMIT_S,
    collect,
    fast_profile,
    free_udp_port,
    healths,
    wait_bound,
)
from tests.helpers import REPO
from trimd.app.connect import open_link
from trimd.core.profile import Profile
from trimd.core.samples import HoldAttitude, PilotInput, Sample
from trimd.drivers.mavlink.link import MavlinkLink
from trimd.drivers.mavlink.rates import RateWatch
from trimd.drivers.mavlink.stations import STICK_THRESHOLD, Stations, stick_deflection
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.dynamics import euler_from_quaternion
from trimd.drivers.sim.mavlink_server import MavlinkServer, open_mavlink2
from trimd.drivers.sim.vehicle import SimVehicle

RATE = 5.0          # simulated seconds per wall second of the in-thread server
_MANUAL = 19        # ArduSub custom mode numbers
_ALT_HOLD = 2


class PilotStation(threading.Thread):
    """A pymavlink ground station as QGroundControl (sysid 255, component 190) with a
    joystick: a heartbeat each second and MANUAL_CONTROL at 20 Hz (neutral unless
    :attr:`sticks` says otherwise); records every message it receives with its wall time.
    ``failsafe_off``: first switch ArduSub's pilot-input failsafe off (PARAM_SET
    FS_PILOT_INPUT = 0, every 0.2 s until the vehicle confirms): at 10× its 3 s are 0.3 s
    of wall time, which a loaded machine can miss between two MANUAL_CONTROL."""

    def __init__(self, port: int, *, failsafe_off: bool = False) -> None:
        super().__init__(daemon=True)
        self.conn = open_mavlink2(f"udpout:127.0.0.1:{port}", 255, 190)
        self.sticks = (0, 0, 500, 0)    # x, y, z, r: neutral
        self.failsafe_on = failsafe_off  # still to switch off
        self.received: list[tuple[float, Any]] = []
        self.stop = threading.Event()
        self._lock = threading.Lock()

    def run(self) -> None:
        next_beat = next_param = 0.0
        while not self.stop.is_set():
            now = time.monotonic()
            with self._lock:
                if self.failsafe_on and now >= next_param:
                    self.conn.mav.param_set_send(1, 1, b"FS_PILOT_INPUT", 0,
                                                 mavlink2.MAV_PARAM_TYPE_INT8)
                    next_param = now + 0.2
                if now >= next_beat:
                    self.conn.mav.heartbeat_send(mavlink2.MAV_TYPE_GCS,
                                                 mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, 4)
                    next_beat = now + 1.0
                self.conn.mav.manual_control_send(1, *self.sticks, 0)
            end = now + 0.05
            while (left := end - time.monotonic()) > 0:
                msg = self.conn.recv_match(blocking=True, timeout=left)
                if msg is not None:
                    self.received.append((time.monotonic(), msg))
                    if (msg.get_type() == "PARAM_VALUE" and msg.param_id == "FS_PILOT_INPUT"
                            and msg.param_value == 0):
                        self.failsafe_on = False
        self.conn.close()

    def set_mode(self, number: int) -> None:
        with self._lock:
            self.conn.mav.command_long_send(1, 1, mavlink2.MAV_CMD_DO_SET_MODE, 0, 1, number,
                                            0, 0, 0, 0, 0)

    def request_streams(self, hz: int) -> None:
        """REQUEST_DATA_STREAM for all streams, as MAVProxy does every 15 s (4 Hz)."""
        with self._lock:
            self.conn.mav.request_data_stream_send(1, 1, mavlink2.MAV_DATA_STREAM_ALL, hz, 1)

    def got(self, kind: str, after: float = 0.0) -> list[Any]:
        """Messages of ``kind`` received after wall time ``after``."""
        return [m for t, m in list(self.received) if t > after and m.get_type() == kind]

    def wait_for(self, cond: Callable[[], bool]) -> None:
        """Until ``cond()`` holds (what the station received so far; hang guard only)."""
        deadline = time.monotonic() + WALL_LIMIT_S
        while not cond():
            if time.monotonic() > deadline:
                raise AssertionError("the pilot's station gave up waiting")
            time.sleep(0.01)


class Handled:
    """What the served simulator handled, with the vehicle's time [s] it handled it at
    (wraps :meth:`MavlinkServer.handle`)."""

    def __init__(self, server: MavlinkServer) -> None:
        self.seen: list[tuple[float, str]] = []
        handle = server.handle

        def recording(msg: Any) -> None:
            self.seen.append((server.vehicle.t_s, msg.get_type()))
            handle(msg)

        server.handle = recording  # type: ignore[method-assign]

    def first(self, kind: str) -> float | None:
        """The vehicle's time the first message of ``kind`` was handled at."""
        return next((t for t, k in list(self.seen) if k == kind), None)


# ------------------------------------------------------------------ units
def test_stick_deflection_counts_from_ardusub_neutral() -> None:
    msg = mavlink2.MAVLink_manual_control_message
    assert stick_deflection(msg(1, 0, 0, 500, 0, 0)) == 0.0
    assert stick_deflection(msg(1, 0, 0, 560, 0, 0)) == pytest.approx(0.12)  # throttle up
    assert stick_deflection(msg(1, -90, 80, 450, 100, 0)) == pytest.approx(0.1)
    assert stick_deflection(msg(1, 0x7FFF, 0x7FFF, 0x7FFF, 0x7FFF, 0)) == 0.0  # all unused
    assert stick_deflection(msg(1, 0, 0, 500, 0, 0, 0, 0b10, 0, 300)) == pytest.approx(0.3)
    assert stick_deflection(msg(1, 0, 0, 500, 0, 0, 0, 0b00, 0, 300)) == 0.0   # t not enabled


def test_stations_come_go_and_only_sticks_to_the_vehicle_count() -> None:
    mav = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)
    beat = mav.heartbeat_encode(mavlink2.MAV_TYPE_GCS, 8, 0, 0, 4)
    beat.pack(mav)              # sets the sender ids on the message
    stations = Stations(own=(254, 190))
    assert stations.heartbeat(beat, 10.0) == (255, 190)
    assert stations.heartbeat(beat, 11.0) is None           # known
    assert stations.present(13.9) == [(255, 190)] and stations.gone(13.9) == []
    stations.heard((255, 190), 13.0)                    # e.g. its stick input
    stations.heard((7, 1), 13.0)                        # not a station: not added
    assert stations.present(15.9) == [(255, 190)]
    assert stations.gone(16.1) == [(255, 190)] and stations.present(16.1) == []
    assert stations.heartbeat(beat, 20.0) == (255, 190)     # back
    sub = mav.heartbeat_encode(mavlink2.MAV_TYPE_SUBMARINE, 3, 0, 0, 4)
    sub.pack(mav)
    assert stations.heartbeat(sub, 20.0) is None             # not a ground station
    sticks = mav.manual_control_encode(1, 300, 0, 500, 0, 0)
    sticks.pack(mav)
    assert stations.stick_input(sticks, 1) == "stick input from sysid 255 (30% of full " \
        "deflection)"
    assert stations.stick_input(sticks, 2) is None           # another vehicle
    assert "give trimd another one" in Stations(own=(255, 190)).describe((255, 190))
    assert STICK_THRESHOLD == 0.1


# ------------------------------------------------------------------ in-process, routed
@pytest.fixture()
def beside_pilot(bluerov: Profile
                 ) -> Iterator[tuple[MavlinkLink, PilotStation, SimVehicle, Handled]]:
    """trimd's link (the default pilot=hold: neutral sticks during a hold if it were
    alone) and a pilot's station, both on the served simulator, armed in MANUAL; what
    the simulator handled."""
    trimd_port, pilot_port = free_udp_port(), free_udp_port()
    link = asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:{trimd_port}?timeout=2", bluerov))
    assert isinstance(link, MavlinkLink)
    vehicle = SimVehicle(bluerov, SimConfig(payload="0.4@W-aft-ctr", armed=True,
                                            mode="MANUAL", seed=1))
    server = MavlinkServer(vehicle, [f"udpout:127.0.0.1:{trimd_port}",
                                     f"udpin:127.0.0.1:{pilot_port}"], rate=RATE)
    handled = Handled(server)
    pilot = PilotStation(pilot_port)
    stop = threading.Event()
    thread = threading.Thread(target=server.run, args=(stop,), daemon=True)
    thread.start()
    pilot.start()
    yield link, pilot, vehicle, handled
    pilot.stop.set()
    stop.set()
    thread.join(timeout=5)
    pilot.join(timeout=5)
    asyncio.run(link.close())


@pytest.mark.parametrize("takeover", ["sticks", "mode"])
def test_beside_a_pilot_trimd_sends_no_sticks_and_yields_at_once(
        beside_pilot: tuple[MavlinkLink, PilotStation, SimVehicle, Handled],
        takeover: str) -> None:
    link, pilot, vehicle, _ = beside_pilot
    target = (0.0, math.radians(15), 0.3)

    async def go() -> tuple[list[Sample], float]:
        stream = link.samples()
        seen = await collect(link, lambda s: any(
            "ground station sysid 255 component 190" in h.detail for h in healths(s)), stream)
        pilot.sticks = (300, 0, 500, 0)     # the pilot flies before trimd commands: fine
        t_end = vehicle.t_s + 3.0
        seen += await collect(link, lambda s: vehicle.t_s >= t_end, stream)
        pilot.sticks = (0, 0, 500, 0)
        # let the neutral sticks reach the link first: on a loaded machine a 30 % stick
        # message still in flight would (rightly) count as a takeover of trimd's hold
        t_end = vehicle.t_s + 2.0
        seen += await collect(link, lambda s: vehicle.t_s >= t_end, stream)
        assert not any(isinstance(x, PilotInput) for x in seen)
        await link.send(HoldAttitude(*target))
        t_end = vehicle.t_s + 15.0   # and the router passed on a few of trimd's targets
        seen += await collect(link, lambda s: vehicle.t_s >= t_end and len(
            pilot.got("SET_ATTITUDE_TARGET")) > 10, stream)
        if takeover == "sticks":
            pilot.sticks = (400, 0, 500, 0)                  # forward, 40 %
        else:
            pilot.set_mode(_MANUAL)
        seen += await collect(link, lambda s: any(isinstance(x, PilotInput) for x in s), stream)
        t_yield = time.monotonic()
        t_end = vehicle.t_s + 5.0
        seen += await collect(link, lambda s: vehicle.t_s >= t_end, stream)
        return seen, t_yield

    samples, t_yielded = asyncio.run(go())
    detail = healths(samples)[-1].detail
    assert "is connected: trimd sends no MANUAL_CONTROL beside it" in detail
    assert "no other ground station seen" not in detail
    # the router passed trimd's hold on to the pilot's station, and no stick input at all
    targets = pilot.got("SET_ATTITUDE_TARGET")
    assert len(targets) > 10
    assert pilot.got("MANUAL_CONTROL") == []
    assert all(m.get_srcSystem() == 1 for m in pilot.got("COMMAND_ACK"))

    taken = [s for s in samples if isinstance(s, PilotInput)]
    assert len(taken) == 1
    # the targets the pilot's station received, in order, and those after trimd yielded
    # (one trimd sent just before may still have been on its way through the router)
    pitch = [euler_from_quaternion(*m.q)[1] for m in pilot.got("SET_ATTITUDE_TARGET")]
    after = [euler_from_quaternion(*m.q)[1] for m in pilot.got("SET_ATTITUDE_TARGET", t_yielded)]
    if takeover == "sticks":
        assert taken[0].source.startswith("stick input from sysid 255 (40% of full")
        # one level target (ArduSub would hold the tilted one for 5 s), then silence:
        # the last target is the level one, and at most one came after trimd yielded
        # besides a tilted one under way
        assert abs(pitch[-1]) < 1e-6 and abs(pitch[-2] - target[1]) < 1e-6, pitch[-3:]
        assert sum(abs(a) < 1e-6 for a in after) <= 1 and len(after) <= 2, after
        assert healths(samples)[-1].mode == "ALT_HOLD"       # the pilot's mode, not restored
    else:
        assert taken[0].source == "mode changed to MANUAL by another station"
        assert all(abs(a - target[1]) < 1e-6 for a in pitch), pitch    # no level one
        assert len(after) <= 1, after                      # one under way at most
        assert healths(samples)[-1].mode == "MANUAL"
    # no mode "restored" over it (a message-interval request is no mode: a loaded machine
    # that slows the served vehicle's streams makes trimd ask for its rates again)
    assert [m for m in pilot.got("COMMAND_LONG", t_yielded)
            if m.command == mavlink2.MAV_CMD_DO_SET_MODE] == []


def vehicle_rate(msgs: list[Any], t0: float, t1: float) -> float:
    """Messages per second of vehicle time (``time_boot_ms``) within [t0, t1)."""
    return sum(t0 <= m.time_boot_ms / 1000 < t1 for m in msgs) / (t1 - t0)


def test_a_station_lowering_the_rates_is_noticed_and_asked_again(
        beside_pilot: tuple[MavlinkLink, PilotStation, SimVehicle, Handled]) -> None:
    link, pilot, vehicle, handled = beside_pilot

    async def go() -> list[Sample]:
        stream = link.samples()
        t_end = vehicle.t_s + 12.0
        await collect(link, lambda s: vehicle.t_s >= t_end, stream)
        pilot.request_streams(2)
        return await collect(link, lambda s: (
            (low := handled.first("REQUEST_DATA_STREAM")) is not None
            and vehicle.t_s >= low + 25.5), stream)

    samples = asyncio.run(go())
    low = handled.first("REQUEST_DATA_STREAM")   # the vehicle's time the request took effect
    assert low is not None
    # what the vehicle sent up to low + 25 s has reached the pilot's station
    pilot.wait_for(lambda: any(m.time_boot_ms / 1000 >= low + 25 for m in pilot.got("ATTITUDE")))
    attitude = pilot.got("ATTITUDE")
    before, during, after = (vehicle_rate(attitude, low - 5, low),
                             vehicle_rate(attitude, low + 0.3, low + 1.5),
                             vehicle_rate(attitude, low + 15, low + 25))
    print(f"ATTITUDE per vehicle second: {before:.1f} before, {during:.1f} just after the "
          f"other station's 2 Hz request, {after:.1f} 15..25 s later")
    assert before == pytest.approx(10, rel=0.1)
    assert during == pytest.approx(2, abs=1)
    assert after == pytest.approx(10, rel=0.1)
    asked = [m for m in pilot.got("COMMAND_LONG")
             if m.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL]
    assert {int(m.param1) for m in asked[-3:]} == {30, 36, 74}  # attitude, servo, depth
    warnings = [w for w in healths(samples)[-1].warnings() if w.startswith("the vehicle sent")]
    assert len(warnings) == 1 and "not the 10 Hz trimd asked for" in warnings[0], warnings


# ------------------------------------------------------------------ trimd run, end to end
@contextlib.contextmanager
def trim_beside_pilot(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[str], PilotStation]]:
    """``trimd run --headless --yes --json`` and a pilot's station on ``trimd sim`` (10×)
    served on two endpoints; everything stopped on the way out."""
    profile, trimd_port, pilot_port = (fast_profile(tmp_path, "sabertooth-dh2"),
                                       free_udp_port(), free_udp_port())
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.Popen(
        [*TRIMD, "run", "--link", f"mavlink:udpin:127.0.0.1:{trimd_port}", "--profile",
         str(profile), "--headless", "--yes", "--json", "--no-record"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)
    procs = [run]
    pilot = PilotStation(pilot_port, failsafe_off=True)
    try:
        wait_bound(trimd_port, run)
        procs.append(subprocess.Popen(
            [*TRIMD, "sim", "--profile", str(profile), "--payload", "10@AftSB", "--serve",
             f"mavlink:udpout:127.0.0.1:{trimd_port}", "--serve",
             f"mavlink:udpin:127.0.0.1:{pilot_port}", "--rate", "10", "--options",
             "armed=true,mode=ALT_HOLD"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env))
        pilot.start()
        yield run, pilot
    finally:
        pilot.stop.set()
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
            proc.wait()
        if pilot.is_alive():
            pilot.join(timeout=5)


def until_collecting(run: subprocess.Popen[str]) -> list[dict[str, Any]]:
    """trimd run's JSON lines up to the first one of a hold collecting data."""
    assert run.stdout is not None
    lines: list[dict[str, Any]] = []
    for line in run.stdout:
        lines.append(json.loads(line))
        if lines[-1].get("phase") == "collect":
            return lines
    raise AssertionError(f"trimd run ended before collecting: {lines[-5:]}")


@pytest.mark.slow
@pytest.mark.parametrize("takeover", ["sticks", "mode"])
def test_trimd_run_releases_and_exits_1_when_the_pilot_takes_over(
        tmp_path: Path, takeover: str) -> None:
    with trim_beside_pilot(tmp_path) as (run, pilot):
        lines = until_collecting(run)
        if takeover == "sticks":
            pilot.sticks = (0, 0, 800, 0)        # throttle up, 60 %
        else:
            pilot.set_mode(_MANUAL)
        t_takeover = time.monotonic()
        out, err = run.communicate(timeout=60)
    assert run.returncode == 1, err
    reason = ("stick input from sysid 255" if takeover == "sticks"
              else "mode changed to MANUAL by another station")
    assert f"the pilot took over ({reason}" in err, err
    lines += [json.loads(x) for x in out.splitlines()]
    assert not any(x.get("type") == "result" for x in lines)   # no estimate from the data
    assert any("is connected: trimd sends no MANUAL_CONTROL" in x.get("text", "")
               for x in lines if x.get("type") == "warning")
    assert pilot.got("MANUAL_CONTROL") == []
    assert len(pilot.got("SET_ATTITUDE_TARGET")) > 10
    # released: at most the one level target (in flight or sent on the takeover)
    late = pilot.got("SET_ATTITUDE_TARGET", t_takeover + 1.0)
    assert all(abs(euler_from_quaternion(*m.q)[1]) < 1e-6 for m in late) and len(late) <= 1


@pytest.mark.slow
def test_trimd_run_completes_when_the_pilots_station_lowers_the_rates(tmp_path: Path) -> None:
    with trim_beside_pilot(tmp_path) as (run, pilot):
        lines = until_collecting(run)
        t_low = time.monotonic()
        pilot.request_streams(2)                # every stream at 2 Hz, mid-hold
        out, err = run.communicate(timeout=150)
    assert run.returncode == 0, err
    lines += [json.loads(x) for x in out.splitlines()]
    assert lines[-1]["type"] == "result"
    warnings = [x["text"] for x in lines if x.get("type") == "warning"]
    assert any(w.startswith("the vehicle sent ") and "asked again" in w for w in warnings), (
        warnings)
    asked = [m for m in pilot.got("COMMAND_LONG", t_low)
             if m.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL]
    assert {int(m.param1) for m in asked} >= {30, 36, 74}      # attitude, servo, depth
    assert pilot.got("MANUAL_CONTROL") == []


# ------------------------------------------------------------------ the rate watch
def _timed(kind: str, t_s: float) -> Any:
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    if kind == "ATTITUDE":
        msg = mav.attitude_encode(round(t_s * 1000), 0, 0, 0, 0, 0, 0)
    else:
        msg = mav.vfr_hud_encode(0, 0, 0, 0, -5.0, 0)
    msg.pack(mav)
    return msg


def _feed(watch: RateWatch, t0: float, t1: float, attitude_hz: float, depth_hz: float
          ) -> list[tuple[float, list[tuple[str, float]]]]:
    """ATTITUDE (the clock) and VFR_HUD at those rates from t0 to t1; what low() said."""
    events = sorted([(t0 + k / attitude_hz, "ATTITUDE")
                     for k in range(round((t1 - t0) * attitude_hz))]
                    + [(t0 + (k + 0.5) / depth_hz, "VFR_HUD")
                       for k in range(round((t1 - t0) * depth_hz))])
    said = []
    for t, kind in events:
        watch.note(_timed(kind, t))
        said.append((t, watch.low()))
    return said


def test_the_rate_watch_notices_a_lowered_rate_and_a_silence() -> None:
    watch = RateWatch()
    _feed(watch, 0.0, 1.0, 10, 5)                       # the clock is known
    watch.asked_for("ATTITUDE", 10.0)
    watch.asked_for("VFR_HUD", 5.0)
    assert all(low == [] for _, low in _feed(watch, 1.0, 20.0, 10, 5))
    assert watch.rate("ATTITUDE") == pytest.approx(10, abs=0.3)
    said = _feed(watch, 20.0, 30.0, 4, 2)               # another station: 4 Hz and 2 Hz
    first = next((t, low) for t, low in said if low)
    assert 20.0 < first[0] < 23.0, first                 # noticed within 3 s (5 s window)
    assert {name for name, _ in first[1]} <= {"ATTITUDE", "VFR_HUD"}
    watch.forget("ATTITUDE")
    watch.forget("VFR_HUD")
    assert watch.low() == []                             # asked again: not judged meanwhile

    # a drop to 0.5 Hz is noticed by its silence after 0.6 s, not after a whole window
    slow = RateWatch()
    _feed(slow, 0.0, 1.0, 10, 5)
    slow.asked_for("VFR_HUD", 5.0)
    said = _feed(slow, 1.0, 10.0, 10, 5) + _feed(slow, 10.0, 14.0, 10, 0.5)
    first_t = next(t for t, low in said if low)
    assert 10.5 < first_t < 10.8, first_t


def test_the_rate_watch_starts_over_when_the_vehicle_reboots() -> None:
    watch = RateWatch()
    _feed(watch, 100.0, 101.0, 10, 5)
    watch.asked_for("ATTITUDE", 10.0)
    _feed(watch, 101.0, 110.0, 10, 5)
    assert watch.rate("ATTITUDE") == pytest.approx(10, abs=0.3)
    _feed(watch, 0.0, 2.0, 10, 5)                        # booted again: time_boot_ms from 0
    assert watch.rate("ATTITUDE") is None and watch.low() == []
