"""The live MAVLink link end to end on UDP loopback (127.0.0.1 only).

Against the simulated vehicle served as ArduSub (``trimd.drivers.sim.mavlink_server``), in a
thread and as ``trimd sim`` in a subprocess, and against a hand-made vehicle that sends
exactly the packets a test needs. Rates are judged per vehicle heartbeat (the vehicle's
own 1 Hz clock), holds on the vehicle's simulated time; the wall-clock limits only keep a
broken link from hanging the suite. Link-lost comes no earlier than the configured
heartbeat timeout, measured on the link's own sample stamps (how much later depends on the
machine's load: not asserted).
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import AsyncIterator, Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.helpers import PROFILES, REPO, assert_proposal_levels
from trimd.app.connect import open_link
from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import (
    Arm,
    Attitude,
    Battery,
    Depth,
    Health,
    HoldAttitude,
    Release,
    Sample,
    Thrusters,
)
from trimd.drivers.mavlink.link import MavlinkLink
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.dynamics import euler_from_quaternion
from trimd.drivers.sim.mavlink_server import MavlinkServer, open_mavlink2
from trimd.drivers.sim.vehicle import SimVehicle
from trimd.logs.tlog import TlogReader

WALL_LIMIT_S = 120.0    # hang guard for one wait, not a timed assertion
TRIMD = [sys.executable, "-m", "trimd"]


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


async def collect(link: MavlinkLink, until: Callable[[list[Sample]], bool],
                  stream: AsyncIterator[Sample]) -> list[Sample]:
    """Samples from ``stream`` until ``until(samples)`` holds (hang guard: WALL_LIMIT_S)."""
    got: list[Sample] = []
    deadline = time.monotonic() + WALL_LIMIT_S
    while not until(got):
        try:
            got.append(await asyncio.wait_for(anext(stream), deadline - time.monotonic()))
        except TimeoutError:
            raise AssertionError(f"gave up waiting; {link.stats}, last {got[-3:]}") from None
    return got


def healths(samples: list[Sample], connected: bool = True) -> list[Health]:
    return [s for s in samples if isinstance(s, Health) and s.connected is connected]


def per_heartbeat(samples: list[Sample], kind: type) -> float:
    """Samples of ``kind`` per vehicle heartbeat between the first and the last heartbeat."""
    beats = [i for i, s in enumerate(samples) if isinstance(s, Health)]
    inside = samples[beats[0]:beats[-1]]
    return sum(isinstance(s, kind) for s in inside) / (len(beats) - 1)


# ------------------------------------------------------------------ URL and user errors
@pytest.mark.parametrize(("url", "message"), [
    ("mavlink:", "needs a connection"),
    ("mavlink:udp:127.0.0.1", "unknown mavlink connection"),
    ("mavlink:udpin:127.0.0.1:99999", "port='99999'"),
    ("mavlink:serial0", "unknown mavlink connection 'serial0'"),
    ("mavlink:tcpin:0.0.0.0:5760", "not supported by trimd"),
    ("mavlink:flight.tlog", "replay:flight.tlog"),
    ("mavlink:udpin:127.0.0.1:0?colour=red", "unknown mavlink option 'colour'"),
    ("mavlink:udpin:127.0.0.1:0?sysid=0", "sysid='0'"),
    ("mavlink:udpin:127.0.0.1:0?timeout=soon", "timeout='soon'"),
    ("mavlink:udpin:127.0.0.1:0?pilot=sometimes", "hold, always"),
    ("mavlink:udpin:127.0.0.1:0?rate=100", "rate='100': expected Hz between 1 and 50"),
    ("mavlink:udpin:127.0.0.1:0?rate=fast", "rate='fast'"),
    ("mavlink:udpin:127.0.0.1:0?key=/nonexistent/key", "cannot read"),
    ("mavlink:/dev/trimd-no-such-tty", "cannot open mavlink:/dev/trimd-no-such-tty"),
    ("udpin:127.0.0.1:14550", "did you mean 'mavlink:udpin:127.0.0.1:14550'"),
])
def test_unknown_or_bad_urls_are_link_errors(bluerov: Profile, url: str, message: str) -> None:
    with pytest.raises(LinkError, match=message.replace("?", r"\?").replace(".", r"\.")):
        asyncio.run(open_link(url, bluerov))


def test_a_hold_beyond_the_tilt_limit_never_leaves(
        fake_link: tuple[UdpVehicle, MavlinkLink]) -> None:
    _, link = fake_link
    for hold in (HoldAttitude(0.0, math.radians(26), 0.0), HoldAttitude(math.nan, 0.0, 0.0)):
        with pytest.raises(LinkError, match="not sent: a hold"):
            asyncio.run(link.send(hold))


def test_port_in_use_and_refused_tcp_are_link_errors(bluerov: Profile) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        with pytest.raises(LinkError, match=f"cannot listen on udp 127.0.0.1:{port}"):
            asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:{port}", bluerov))
    with socket.socket() as closed:
        closed.bind(("127.0.0.1", 0))
        port = closed.getsockname()[1]      # bound but not listening: refused
        with pytest.raises(LinkError, match="cannot open mavlink:tcp"):
            asyncio.run(open_link(f"mavlink:tcp:127.0.0.1:{port}", bluerov))


def test_signing_key_must_be_32_bytes_or_64_hex(bluerov: Profile, tmp_path: Path) -> None:
    key = tmp_path / "key"
    key.write_text("secret")
    with pytest.raises(LinkError, match="32 raw bytes or 64 hex digits"):
        asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:0?key={key}", bluerov))


# ------------------------------------------------------------------ a hand-made vehicle
class UdpVehicle:
    """A UDP socket that sends MAVLink 2 packets from (sysid, compid) to the link."""

    def __init__(self, port: int, key: bytes | None = None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(WALL_LIMIT_S)
        self.port = port
        self.key = key

    def mav(self, sysid: int = 1, compid: int = 1, key: bytes | None = None) -> Any:
        mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        if key is not None:
            mav.signing.secret_key = key
            mav.signing.sign_outgoing = True
            mav.signing.timestamp = int((time.time() - 1420070400) * 1e5)
        return mav

    def send(self, data: bytes) -> None:
        self.sock.sendto(data, ("127.0.0.1", self.port))

    @staticmethod
    def pack(mav: Any, msg: Any) -> bytes:
        """The packet of ``msg`` with ``mav``'s next sequence number."""
        data = bytes(msg.pack(mav))
        mav.seq = (mav.seq + 1) % 256
        return data

    def heartbeat(self, mav: Any, mode: int = 19, autopilot: int = 3, kind: int = 12) -> bytes:
        return self.pack(mav, mav.heartbeat_encode(kind, autopilot, 1, mode, 4))


@pytest.fixture()
def fake_link(bluerov: Profile) -> Iterator[tuple[UdpVehicle, MavlinkLink]]:
    port = free_udp_port()
    link = asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:{port}", bluerov))
    assert isinstance(link, MavlinkLink)
    yield UdpVehicle(port), link
    asyncio.run(link.close())


def test_bad_frames_gaps_and_other_systems(fake_link: tuple[UdpVehicle, MavlinkLink]) -> None:
    fake, link = fake_link
    vehicle, stranger, gcs = fake.mav(1, 1), fake.mav(2, 1), fake.mav(7, 190)
    raw: list[bytes] = []
    good: list[bytes] = []
    link.on_raw = lambda t_s, packet: raw.append(packet)

    def send(packet: bytes, ok: bool = True) -> None:
        fake.send(packet)
        if ok:
            good.append(packet)

    async def go() -> list[Sample]:
        stream = link.samples()
        send(fake.heartbeat(gcs, kind=6, autopilot=8))              # a GCS: never the vehicle
        send(fake.heartbeat(vehicle))                               # MANUAL, seq 0
        first = await collect(link, lambda s: len(healths(s)) == 1, stream)
        send(fake.heartbeat(stranger, mode=2))                      # another vehicle: ignored
        send(b"\x00garbage\x01\x02", ok=False)                      # one bad stretch
        bad = bytearray(fake.pack(vehicle, vehicle.attitude_encode(0, 0.1, 0, 0, 0, 0, 0)))
        bad[-1] ^= 0xFF                                             # bad CRC, seq 1
        send(bytes(bad), ok=False)
        vehicle.seq += 3                                            # seq 2..4 never sent
        send(fake.pack(vehicle, vehicle.attitude_encode(0, 0.2, 0.1, 0, 0, 0, 0)))
        send(fake.heartbeat(vehicle))
        return first + await collect(link, lambda s: len(healths(s)) == 1, stream)

    samples = asyncio.run(go())
    assert [(h.mode, h.armed) for h in healths(samples)] == [("MANUAL", False)] * 2
    attitudes = [s for s in samples if isinstance(s, Attitude)]
    assert [(round(a.phi, 6), round(a.theta, 6)) for a in attitudes] == [(0.2, 0.1)]
    assert link.stats.bad_frames == 2
    assert healths(samples)[-1].bad_frames == 2
    assert link.stats.gaps[(1, 1)] == 4                             # the bad one and three
    assert link.stats.refused == 0
    assert raw == good                                              # verbatim, in order


class Responder(threading.Thread):
    """The hand-made vehicle answering trimd: a heartbeat each 0.2 s; SET_MESSAGE_INTERVAL
    refused (an old ArduSub); each parameter read answered from ``params``."""

    def __init__(self, fake: UdpVehicle, params: dict[str, float]) -> None:
        super().__init__(daemon=True)
        self.fake, self.params = fake, params
        self.mav = fake.mav(1, 1)
        self.streams: list[tuple[int, int]] = []
        self.stop = threading.Event()
        fake.sock.settimeout(0.2)

    def run(self) -> None:
        parser, mav, fake = mavlink2.MAVLink(None), self.mav, self.fake
        while not self.stop.is_set():
            fake.send(fake.heartbeat(mav))
            try:
                data, _ = fake.sock.recvfrom(300)
            except TimeoutError:
                continue
            msg = parser.parse_char(bytearray(data))
            kind = msg.get_type() if msg is not None else ""
            if kind == "COMMAND_LONG":
                fake.send(fake.pack(mav, mav.command_ack_encode(
                    msg.command, mavlink2.MAV_RESULT_UNSUPPORTED)))
            elif kind == "PARAM_REQUEST_READ":
                value = self.params.get(msg.param_id, 0.0)
                fake.send(fake.pack(mav, mav.param_value_encode(
                    msg.param_id.encode(), value, mavlink2.MAV_PARAM_TYPE_INT16, 30, 0)))
            elif kind == "REQUEST_DATA_STREAM":
                self.streams.append((msg.req_stream_id, msg.req_message_rate))


def test_stream_fallback_and_parameter_warnings(
        fake_link: tuple[UdpVehicle, MavlinkLink]) -> None:
    fake, link = fake_link
    params = {"FRAME_CONFIG": 2.0, "MOT_3_DIRECTION": -1.0,
              **{f"SERVO{n}_FUNCTION": 32.0 + n for n in range(1, 9)}}
    responder = Responder(fake, params)
    responder.start()

    def warned(samples: list[Sample]) -> bool:
        return any("MOT_3_DIRECTION" in h.detail and "VFR_HUD" in h.detail
                   for h in healths(samples))

    async def go() -> list[Sample]:
        return await collect(link, warned, link.samples())

    try:
        samples = asyncio.run(go())
    finally:
        responder.stop.set()
        responder.join()
    detail = healths(samples)[-1].detail
    assert "MOT_3_DIRECTION = -1 but the profile says reversed = false" in detail
    assert "SET_MESSAGE_INTERVAL SERVO_OUTPUT_RAW at 10 Hz: MAV_RESULT_UNSUPPORTED; asked " \
        "with REQUEST_DATA_STREAM (stream 3) instead" in detail
    assert sorted(responder.streams) == [(2, 2), (3, 10), (10, 10), (11, 5)]
    assert link.params.motor_direction[3] == -1 and link.params.frame_config == 2


def test_release_in_alt_hold_levels_the_vehicle_at_once(
        fake_link: tuple[UdpVehicle, MavlinkLink]) -> None:
    """ArduSub honours the last attitude target for 5 s: when the operator was in ALT_HOLD
    already (no mode to restore), Release must send a level target, not merely fall silent."""
    fake, link = fake_link
    vehicle = fake.mav(1, 1)
    reader = mavlink2.MAVLink(None)
    targets: list[tuple[float, float, float]] = []

    def read_until(kind: str) -> list[Any]:
        """What trimd sends, up to and including the first message of ``kind``."""
        got: list[Any] = []
        while not got or got[-1].get_type() != kind:
            data, _ = fake.sock.recvfrom(300)
            got += [m for m in reader.parse_buffer(bytearray(data)) or [] if m is not None]
        return got

    async def go() -> None:
        stream = link.samples()
        fake.send(fake.heartbeat(vehicle, mode=2))                  # ALT_HOLD already
        await collect(link, lambda s: len(healths(s)) == 1, stream)
        await link.send(HoldAttitude(math.radians(20), math.radians(15), 1.0))
        read_until("SET_ATTITUDE_TARGET")
        await link.send(Release())
        got = read_until("HEARTBEAT")                   # what follows, up to 1 s later
        if not any(m.get_type() == "SET_ATTITUDE_TARGET" for m in got):
            got += read_until("HEARTBEAT")              # the release fell after a heartbeat
        targets.extend(euler_from_quaternion(*m.q) for m in got
                       if m.get_type() == "SET_ATTITUDE_TARGET")
        after = read_until("HEARTBEAT")                 # a whole heartbeat period later
        assert not any(m.get_type() in ("SET_ATTITUDE_TARGET", "MANUAL_CONTROL")
                       for m in after)

    asyncio.run(go())
    assert targets, "no attitude target after Release: ArduSub would hold the tilt for 5 s"
    # maybe one tilted target in flight before the release, then level at the hold's heading
    np.testing.assert_allclose(targets[-1], (0.0, 0.0, 1.0), atol=1e-6)
    assert all(t == targets[-1] or t[0] > 0.3 for t in targets)


def test_signing_refuses_unsigned_and_wrongly_signed(bluerov: Profile, tmp_path: Path) -> None:
    key = bytes(range(32))
    (tmp_path / "key").write_text(key.hex())
    port = free_udp_port()
    link = asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:{port}?key={tmp_path / 'key'}",
                                 bluerov))
    assert isinstance(link, MavlinkLink)
    fake = UdpVehicle(port)
    # pymavlink notes a stream's timestamp before it checks the signature: the forged
    # packet must be older than the genuine one, or the genuine one is refused as a replay
    forged, unsigned = fake.mav(1, 1, bytes(32)), fake.mav(1, 1)
    signed = fake.mav(1, 1, key)
    signed.signing.timestamp = forged.signing.timestamp + 1  # both read one 10 µs clock

    reader = mavlink2.MAVLink(None)           # has the key, allows nothing unsigned
    reader.signing.secret_key = key
    sent: list[Any] = []

    async def go() -> list[Sample]:
        stream = link.samples()
        fake.send(fake.heartbeat(unsigned, mode=2))   # e.g. our own commands echoed back
        fake.send(fake.heartbeat(forged, mode=2))
        fake.send(fake.heartbeat(signed))
        try:
            got = await collect(link, lambda s: len(healths(s)) == 1, stream)
            while not any(m.get_type() == "HEARTBEAT" for m in sent):   # what trimd sends
                data, _ = fake.sock.recvfrom(300)
                sent.append(reader.parse_char(bytearray(data)))
            return got
        finally:
            await link.close()

    samples = asyncio.run(go())
    assert [h.mode for h in healths(samples)] == ["MANUAL"]
    assert link.stats.refused == 2 and link.stats.messages == 1
    assert all(m.get_signed() for m in sent)
    assert sent[-1].type == mavlink2.MAV_TYPE_GCS


# ------------------------------------------------------------------ the served simulator
RATE = 5.0  # simulated seconds per wall second of the in-thread server


@pytest.fixture()
def served(bluerov: Profile) -> Iterator[tuple[MavlinkLink, SimVehicle, threading.Event]]:
    port = free_udp_port()
    link = asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:{port}?pilot=always&timeout=1",
                                 bluerov))
    assert isinstance(link, MavlinkLink)
    vehicle = SimVehicle(bluerov, SimConfig(payload="0.4@W-aft-ctr", armed=True, mode="MANUAL",
                                            seed=1))
    server = MavlinkServer(vehicle, f"udpout:127.0.0.1:{port}", rate=RATE)
    stop = threading.Event()
    thread = threading.Thread(target=server.run, args=(stop,), daemon=True)
    thread.start()
    yield link, vehicle, stop
    stop.set()
    thread.join(timeout=5)
    asyncio.run(link.close())


@pytest.mark.parametrize(("query", "stream_hz", "expected"), [
    ("", 50.0, 50.0),          # trimd excite's request
    ("&rate=20", 50.0, 20.0),  # the URL's rate wins
])
def test_the_telemetry_rate_asked_for_is_what_arrives(
        bluerov: Profile, query: str, stream_hz: float, expected: float) -> None:
    """Attitude, thruster outputs and depth at the rate asked (``trimd excite`` asks for
    50 Hz unless the URL says ``rate=``); the rest at trimd's usual rates."""
    port = free_udp_port()
    link = asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:{port}?pilot=always&timeout=1"
                                 + query, bluerov, stream_hz=stream_hz))
    assert isinstance(link, MavlinkLink)
    vehicle = SimVehicle(bluerov, SimConfig(armed=True, mode="MANUAL", seed=1))
    server = MavlinkServer(vehicle, f"udpout:127.0.0.1:{port}", rate=RATE)
    stop = threading.Event()
    thread = threading.Thread(target=server.run, args=(stop,), daemon=True)
    thread.start()

    async def go() -> list[Sample]:
        stream = link.samples()
        await collect(link, lambda s: len(healths(s)) == 2, stream)
        return await collect(link, lambda s: len(healths(s)) == 7, stream)

    try:
        got = asyncio.run(go())
    finally:
        stop.set()
        thread.join(timeout=5)
        asyncio.run(link.close())
    for kind in (Attitude, Thrusters, Depth):
        assert per_heartbeat(got, kind) == pytest.approx(expected, rel=0.15), kind
    assert per_heartbeat(got, Battery) == pytest.approx(2, rel=0.3)


def test_rates_hold_release_and_link_lost(
        served: tuple[MavlinkLink, SimVehicle, threading.Event]) -> None:
    link, vehicle, stop = served
    target = (math.radians(10), math.radians(15), 0.3)

    async def go() -> None:
        stream = link.samples()
        # telemetry at the requested rates, per vehicle heartbeat (after the requests land)
        await collect(link, lambda s: len(healths(s)) == 2, stream)
        got = await collect(link, lambda s: len(healths(s)) == 9, stream)
        print("per heartbeat:", {k.__name__: per_heartbeat(got, k)
                                 for k in (Attitude, Thrusters, Depth, Battery)})
        assert per_heartbeat(got, Attitude) == pytest.approx(10, rel=0.15)
        assert per_heartbeat(got, Thrusters) == pytest.approx(10, rel=0.15)   # default 2
        assert per_heartbeat(got, Depth) == pytest.approx(5, rel=0.2)
        assert per_heartbeat(got, Battery) == pytest.approx(2, rel=0.3)
        assert {(h.mode, h.armed) for h in healths(got)} == {("MANUAL", True)}  # pilot=always
        assert link.params.frame_config == 2 and link.params.servo_function[8] == 40
        assert [w.split(':')[0] for w in link.warnings] == [  # the pilot-input case only
            "no other ground station seen"]

        # a hold the vehicle reaches, in ALT_HOLD, for 30 s of vehicle time
        await link.send(HoldAttitude(*target))
        t_end = vehicle.t_s + 30.0
        held = await collect(link, lambda s: vehicle.t_s >= t_end, stream)
        assert healths(held)[-1].mode == "ALT_HOLD" and healths(held)[-1].armed
        late = [s for s in held if isinstance(s, Attitude)][-30:]
        for a in late:
            assert abs(a.phi - target[0]) < math.radians(1)
            assert abs(a.theta - target[1]) < math.radians(1)
            assert abs(a.psi - target[2]) < math.radians(2)

        # release restores the operator's mode
        await link.send(Release())
        back = await collect(link, lambda s: any(h.mode == "MANUAL" for h in healths(s)), stream)
        assert healths(back)[-1].armed

        # disarm through COMMAND_LONG, confirmed by the vehicle's ACK
        await link.send(Arm(False))
        back += await collect(link, lambda s: any(not h.armed for h in healths(s)), stream)

        # the server stops: link lost, not before the 1 s heartbeat timeout
        stop.set()
        gone = await collect(link, lambda s: bool(healths(s, connected=False)), stream)
        last_beat = healths(back + gone)[-1].t_s
        lost = healths(gone, connected=False)[0]
        print(f"link lost {lost.t_s - last_beat:.3f} s after the last heartbeat")
        assert lost.t_s - last_beat >= 1.0
        assert "no heartbeat from the vehicle (system 1, component 1) for 1 s" in lost.detail

    asyncio.run(go())
    assert link.stats.bad_frames == 0 and link.stats.dropped == 0


# ------------------------------------------------------------------ trimd run ↔ trimd sim
def fast_profile(tmp_path: Path, name: str) -> Path:
    """Profile ``name`` with 3 s instead of 10 s of steadiness before collecting, at most
    60 s of collecting per hold and the commanded tilt moving at 50°/s instead of 5°/s:
    the served simulator runs 10× faster than the wall clock the live procedure
    measures."""
    text = (PROFILES / f"{name}.yaml").read_text(encoding="utf-8")
    assert "min_steady_s: 10.0" in text
    text = re.sub(r"collect_max_s: [\d.]+", "collect_max_s: 60.0", text, count=1)
    path = tmp_path / f"{name}.yaml"
    assert "tilt_rate_deg_s" not in text
    faster = r"\1min_steady_s: 3.0\n\1tilt_rate_deg_s: 50.0"
    path.write_text(re.sub(r"( *)min_steady_s: 10.0", faster, text, count=1), encoding="utf-8")
    return path


def udp_bound(port: int) -> bool:
    """Whether a socket is bound to udp ``port`` (any address), read from the kernel's
    table: probing by binding the port ourselves would, for an instant, take it from the
    process that is about to bind it (which then exits with "address already in use")."""
    needle = f":{port:04X}"
    for table in (Path("/proc/net/udp"), Path("/proc/net/udp6")):
        if table.exists():
            lines = table.read_text(encoding="ascii").splitlines()[1:]
            if any(line.split()[1].endswith(needle) for line in lines):
                return True
    return False


def wait_bound(port: int, proc: subprocess.Popen[Any] | None = None) -> None:
    """Until something binds udp 127.0.0.1:port (trimd run's link is listening); fails at
    once, with its stderr, if ``proc`` (the process that should bind it) has exited."""
    deadline = time.monotonic() + WALL_LIMIT_S
    while time.monotonic() < deadline:
        if udp_bound(port):
            return
        if proc is not None and proc.poll() is not None:
            err = proc.stderr.read() if proc.stderr is not None else ""
            raise AssertionError(f"exited ({proc.returncode}) before binding udp {port}: {err}")
        time.sleep(0.05)
    raise AssertionError(f"nothing listens on udp {port}")


def switch_off_pilot_failsafe(port: int) -> None:
    """PARAM_SET FS_PILOT_INPUT = 0 to the simulator serving udp ``port`` (one of its
    endpoints) until the vehicle confirms: the 10× simulator's 3 s failsafe is 0.3 s of
    wall time, which trimd's MANUAL_CONTROL (10 Hz of wall time) can miss on a loaded
    machine, and then the vehicle disarms mid-trim."""
    conn = open_mavlink2(f"udpin:127.0.0.1:{port}", 254, 1)
    deadline = time.monotonic() + WALL_LIMIT_S                    # hang guard
    try:
        while time.monotonic() < deadline:
            conn.mav.param_set_send(1, 1, b"FS_PILOT_INPUT", 0, mavlink2.MAV_PARAM_TYPE_INT8)
            msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.2)
            if msg is not None and msg.param_id == "FS_PILOT_INPUT" and msg.param_value == 0:
                return
        raise AssertionError("the vehicle never confirmed FS_PILOT_INPUT = 0")
    finally:
        conn.close()


def start_pair(tmp_path: Path, name: str, payload: str, log: Path
               ) -> tuple[subprocess.Popen[str], subprocess.Popen[str]]:
    """``trimd run`` listening on a UDP port, then ``trimd sim`` serving to it, armed, its
    pilot-input failsafe switched off through a second endpoint (what these tests judge
    does not hang on a loaded machine delivering trimd's stick input in time)."""
    profile, port, helper = fast_profile(tmp_path, name), free_udp_port(), free_udp_port()
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.Popen(
        [*TRIMD, "run", "--link", f"mavlink:udpin:127.0.0.1:{port}?pilot=always", "--profile",
         str(profile), "--headless", "--yes", "--json", "--record", str(log)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)
    wait_bound(port, run)
    sim = subprocess.Popen(
        [*TRIMD, "sim", "--profile", str(profile), "--payload", payload, "--serve",
         f"mavlink:udpout:127.0.0.1:{port}", "--serve", f"mavlink:udpout:127.0.0.1:{helper}",
         "--rate", "10", "--options", "armed=true,mode=ALT_HOLD"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)
    try:
        switch_off_pilot_failsafe(helper)
    except BaseException:
        for proc in (run, sim):
            proc.kill()
            proc.wait()
        raise
    return run, sim


@pytest.mark.slow
@pytest.mark.parametrize(("name", "payload", "xy_tol", "z_tol", "m_tol"), [
    # T200 dead band, a payload off the slots; the Sabertooth's trim over MAVLink, with
    # its log replayed, is tests/drivers/test_mavlink_mavproxy.py's (through MAVProxy)
    ("bluerov2-heavy", "0.3@0.05,0.1,-0.1", 3e-3, 5e-3, 0.1),
])
def test_trimd_run_over_mavlink_estimates_the_served_vehicle(
        tmp_path: Path, name: str, payload: str, xy_tol: float, z_tol: float,
        m_tol: float) -> None:
    log = tmp_path / "session.tlog"
    run, sim = start_pair(tmp_path, name, payload, log)
    try:
        out, err = run.communicate(timeout=150)
    finally:
        sim.kill()
        sim.wait()
    assert run.returncode == 0, err
    result = json.loads(out.splitlines()[-1])
    assert result["type"] == "result"
    truth = SimVehicle(load_profile(name), SimConfig(payload=payload)).truth
    err_cg = np.asarray(result["estimate"]["cg_m"]) - np.asarray(truth.mass.r_g)
    print("estimate − truth: cg", err_cg, "m_ext", result["estimate"]["m_ext_kg"] - truth.m_ext_kg)
    assert np.all(np.abs(err_cg[:2]) < xy_tol) and abs(err_cg[2]) < z_tol, err_cg
    # the target, or the estimate's own 95 % interval where that is wider (the Sabertooth's
    # carries the thrust curves' 5 %: ≈ ±1 kg)
    assert abs(result["estimate"]["m_ext_kg"] - truth.m_ext_kg) < max(
        m_tol, 1.96 * result["estimate"]["m_ext_std_kg"])
    assert result["proposal"]["method"] == "milp"
    assert_proposal_levels(load_profile(PROFILES / f"{name}.yaml"), payload, result["proposal"])
    # the log holds the packets as received; replaying it gives the same numbers
    replayed = subprocess.run([*TRIMD, "replay", str(log), "--json"], capture_output=True,
                              text=True, cwd=REPO, timeout=120, check=True,
                              env={**os.environ, "PYTHONPATH": str(REPO)})
    again = json.loads(replayed.stdout.splitlines()[-1])
    assert again["estimate"] == result["estimate"]
    assert again["proposal"] == result["proposal"]


@pytest.mark.slow
def test_trimd_run_exits_3_with_an_intact_log_when_the_vehicle_dies(tmp_path: Path) -> None:
    log = tmp_path / "session.tlog"
    run, sim = start_pair(tmp_path, "sabertooth-dh2", "10@AftSB", log)
    try:
        assert run.stdout is not None
        for line in run.stdout:                      # until the first hold is commanded
            if json.loads(line).get("type") == "command":
                break
        sim.send_signal(signal.SIGKILL)
        sim.wait()
        _, err = run.communicate(timeout=60)
    finally:
        for p in (run, sim):
            if p.poll() is None:
                p.kill()
    assert run.returncode == 3, err
    # the link's heartbeat timeout and the procedure's telemetry timeout are both 3 s:
    # whichever notices first says so
    assert re.search(r"link lost: no (heartbeat from the vehicle|telemetry for)", err), err
    reader = TlogReader.open(log)
    texts = [m.text for _, m in reader.messages() if m.get_type() == "STATUSTEXT"]
    st = reader.stats
    assert st.bad_frames == 0 and st.truncated_at is None and st.accounted_bytes == st.size_bytes
    assert any(re.match(r"link lost: no (heartbeat|telemetry)", t) for t in texts), texts[-8:]
    assert "trimd: release control" in texts
    replayed = subprocess.run([*TRIMD, "replay", str(log)], capture_output=True, text=True,
                              cwd=REPO, timeout=60, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert "link lost" in replayed.stdout + replayed.stderr, (
        replayed.returncode, replayed.stdout[-1500:], replayed.stderr[-1500:], texts[-8:])


@pytest.mark.parametrize(("link", "url"), [
    ("mavlink:udpin:127.0.0.1:0", "mavlink:udpin:127.0.0.1:0?sysid=7"),
    ("mavlink:udpin:127.0.0.1:0?timeout=2", "mavlink:udpin:127.0.0.1:0?timeout=2&sysid=7"),
    ("mavlink:udpin:127.0.0.1:0?sysid=2", None),   # asked twice
    ("sim:payload=10@AftSB", None),                # not a MAVLink link
])
def test_sysid_option_goes_into_the_mavlink_url(
        link: str, url: str | None, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import trimd.app.connect
    from trimd.cli.main import main

    opened: list[str] = []

    async def fake_open(u: str, profile: object) -> object:
        opened.append(u)
        raise LinkError("stop here")

    monkeypatch.setattr(trimd.app.connect, "open_link", fake_open)
    code = main(["run", "--link", link, "--profile", "sabertooth-dh2", "--sysid", "7",
                 "--headless", "--yes", "--no-record"])
    if url is None:
        assert code == 2 and opened == [] and "--sysid is for a mavlink" in capsys.readouterr().err
    else:
        assert code == 3 and opened == [url]


@pytest.mark.parametrize("sysid", ["0", "256", "one"])
def test_sysid_option_out_of_range_is_a_usage_error(
        sysid: str, capsys: pytest.CaptureFixture[str]) -> None:
    from trimd.cli.main import main

    assert main(["run", "--link", "mavlink:udpin:127.0.0.1:0", "--profile", "sabertooth-dh2",
                 "--sysid", sysid]) == 2
    assert "--sysid: expected an integer in 1…255" in capsys.readouterr().err
