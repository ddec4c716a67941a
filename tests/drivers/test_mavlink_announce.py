"""trimd's own messages on the MAVLink network (``trimd/drivers/mavlink/outbox.py``): the
heartbeat, STATUSTEXT and NAMED_VALUE_FLOAT as pymavlink decodes them, their budget on a
clock the test sets, the ``ids=`` / ``comp=`` / ``announce=`` URL options (as a component
of the vehicle, no sticks), and the exact set of message types a live watch sends,
sniffed behind the simulator's router."""

from __future__ import annotations

import asyncio
import math
import threading
import time
from collections import Counter
from concurrent.futures import Future
from typing import Any

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.drivers.test_mavlink_link import WALL_LIMIT_S, free_udp_port
from trimd.app.connect import open_link
from trimd.app.watch import watch_link
from trimd.core.announce import Severity, Text, Values
from trimd.core.change import ChangeAlert
from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Health, HoldAttitude, OpenLoop, Sample
from trimd.core.segment import SegmentEstimate
from trimd.core.watch import TrimWatch, WatchAlert, WatchSegment
from trimd.drivers.mavlink.commands import Commander
from trimd.drivers.mavlink.decode import MavlinkDecoder
from trimd.drivers.mavlink.outbox import MAX_WAITING, TEXT_PERIOD_S, VALUE_PERIOD_S, Outbox
from trimd.drivers.mavlink.stations import Stations
from trimd.drivers.mavlink.url import parse_mavlink_url
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.mavlink_server import MavlinkServer, open_mavlink2
from trimd.drivers.sim.vehicle import SimVehicle


class Wire:
    """What an outbox wrote, decoded as a ground station decodes it."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.parser = mavlink2.MAVLink(None)
        self.parser.robust_parsing = True

    def write(self, buf: bytes) -> None:
        self.data.extend(buf)

    def messages(self) -> list[Any]:
        out = self.parser.parse_buffer(bytes(self.data)) or []
        self.data.clear()
        return list(out)


def outbox(enabled: bool = True, mav_type: int = mavlink2.MAV_TYPE_ONBOARD_CONTROLLER
           ) -> tuple[Outbox, Wire]:
    wire = Wire()
    return Outbox(mavlink2.MAVLink(wire, srcSystem=1, srcComponent=191), mav_type=mav_type,
                  t0=0.0, enabled=enabled), wire


def joined(msgs: list[Any]) -> list[tuple[int, str]]:
    """STATUSTEXT chunks joined per id, as MAVProxy does: (severity, text)."""
    texts: list[tuple[int, str]] = []
    pending: dict[int, list[str]] = {}
    for m in msgs:
        if m.get_type() != "STATUSTEXT":
            continue
        if m.id == 0:
            texts.append((m.severity, m.text))
            continue
        pending.setdefault(m.id, []).append(m.text)
        if len(m.text) < 50:
            texts.append((m.severity, "".join(pending.pop(m.id))))
    return texts


# ------------------------------------------------------------------ encoding
def test_texts_are_ascii_and_chunked_with_an_id_beyond_50_bytes() -> None:
    box, wire = outbox()
    box.put(Text(Severity.ALERT, "TRIMD heavier 2.4±0.1N since 5min: water?"))
    long = "TRIMD stbd-heavy 0.031±0.005Nm since 12min: weight stbd? " * 2
    box.put(Text(Severity.CRITICAL, long))
    box.tick(0.0)
    msgs = wire.messages()
    texts = [m for m in msgs if m.get_type() == "STATUSTEXT"]
    assert texts[0].id == 0 and texts[0].chunk_seq == 0 and texts[0].severity == 1
    assert texts[0].text == "TRIMD heavier 2.4+-0.1N since 5min: water?"
    assert len({m.id for m in texts[1:]}) == 1 and texts[1].id != 0
    assert [m.chunk_seq for m in texts[1:]] == list(range(len(texts) - 1))
    assert joined(msgs)[1] == (2, long.replace("±", "+-"))
    beat = next(m for m in msgs if m.get_type() == "HEARTBEAT")
    assert (beat.type, beat.autopilot) == (18, 8)
    assert (beat.get_srcSystem(), beat.get_srcComponent()) == (1, 191)


def test_a_text_of_exactly_two_chunks_ends_with_an_empty_one() -> None:
    box, wire = outbox()
    box.put(Text(Severity.ALERT, "x" * 100))
    box.tick(0.0)
    chunks = [m for m in wire.messages() if m.get_type() == "STATUSTEXT"]
    assert [len(m.text) for m in chunks] == [50, 50, 0]


def test_values_are_named_value_floats_at_most_once_a_second_each() -> None:
    box, wire = outbox()
    box.put(Values((("TRIMD_WB", 2.5), ("TRIMD_MX", -0.01))))
    box.tick(10.0)
    box.put(Values((("TRIMD_WB", 2.6),)))
    box.put(Values((("TRIMD_WB", 2.7),)))       # replaces 2.6 while it waits
    assert box.tick(10.5) == pytest.approx(10.0 + VALUE_PERIOD_S)
    box.tick(11.0)
    got = [(m.name, round(m.value, 3), m.time_boot_ms) for m in wire.messages()
           if m.get_type() == "NAMED_VALUE_FLOAT"]
    assert got == [("TRIMD_WB", 2.5, 10000), ("TRIMD_MX", -0.01, 10000),
                   ("TRIMD_WB", 2.7, 11000)]
    with pytest.raises(ValueError, match="1 to 10 ASCII"):
        Values((("TRIMD_WB_TOO_LONG", 1.0),))


def test_announce_off_sends_the_heartbeat_alone() -> None:
    box, wire = outbox(enabled=False, mav_type=mavlink2.MAV_TYPE_GCS)
    box.put(Text(Severity.ALERT, "TRIMD heavier"))
    box.put(Values((("TRIMD_WB", 1.0),)))
    for t in np.arange(0.0, 3.0, 0.1):
        box.tick(float(t))
    kinds = Counter(m.get_type() for m in wire.messages())
    assert kinds == {"HEARTBEAT": 3} and box.dropped_texts == 1


# ------------------------------------------------------------------ the budget
def test_a_long_dive_never_floods_the_link() -> None:
    """Two simulated hours of a chatty watch: an INFO every second, a NOTICE every
    minute, values every 10 s and an alert every 20 min. Alerts go at once; any other
    text at most one per TEXT_PERIOD_S; no NOTICE is lost while it waits; each value name
    at most once a second; the heartbeat at 1 Hz."""
    box, wire = outbox()
    sent: list[tuple[float, Any]] = []
    t = 0.0
    for k in range(2 * 3600 * 10):          # ticks every 0.1 s
        t = k / 10
        if k % 10 == 0:
            box.put(Text(Severity.INFO, f"TRIMD phase {k}"))
        if k % 600 == 0:
            box.put(Text(Severity.NOTICE, f"TRIMD verdict {k}"))
        if k % 100 == 0:
            box.put(Values((("TRIMD_WB", k / 1e4), ("TRIMD_MX", 0.0), ("TRIMD_MY", 0.0))))
        if k % 12000 == 6000:
            box.put(Text(Severity.ALERT, f"TRIMD heavier alert {k}"))
        box.tick(t)
        sent.extend((t, m) for m in wire.messages())
    texts = [(t, m) for t, m in sent if m.get_type() == "STATUSTEXT"]
    alerts = [(t, m) for t, m in texts if m.severity <= Severity.CRITICAL]
    others = [t for t, m in texts if m.severity > Severity.CRITICAL]
    assert [round(t, 1) for t, _ in alerts] == [600.0 + 1200 * n for n in range(6)]
    assert min(np.diff(others)) >= TEXT_PERIOD_S - 1e-9
    notices = [m.text for _, m in texts if m.severity == Severity.NOTICE]
    assert notices == [f"TRIMD verdict {k}" for k in range(0, 72000, 600)]
    assert len(texts) <= 2 * 3600 / TEXT_PERIOD_S + len(alerts) + 1
    values = [(t, m.name) for t, m in sent if m.get_type() == "NAMED_VALUE_FLOAT"]
    for name in ("TRIMD_WB", "TRIMD_MX", "TRIMD_MY"):
        times = [t for t, n in values if n == name]
        assert len(times) == 720 and min(np.diff(times)) >= VALUE_PERIOD_S - 1e-9
    beats = [t for t, m in sent if m.get_type() == "HEARTBEAT"]
    assert 7100 <= len(beats) <= 7200     # 1 Hz, on a clock ticking every 0.1 s
    assert box.dropped_texts > 0 and box.sent_texts == len(alerts) + len(others)


def test_waiting_texts_are_bounded_and_flushed_on_close() -> None:
    box, wire = outbox()
    box.tick(0.0)
    for n in range(MAX_WAITING + 3):
        box.put(Text(Severity.NOTICE, f"TRIMD notice {n}"))
    box.tick(0.1)
    box.flush(0.2)
    notices = [m.text for m in wire.messages() if m.get_type() == "STATUSTEXT"]
    assert notices == [f"TRIMD notice {n}" for n in range(3, MAX_WAITING + 3)]
    assert box.dropped_texts == 3


# ------------------------------------------------------------------ URL options
@pytest.mark.parametrize(("query", "source", "sysid"), [
    ("", (255, 190), None),
    ("?gcs=254", (254, 190), None),
    ("?ids=vehicle", (1, 191), 1),
    ("?ids=vehicle&sysid=7&comp=194", (7, 194), 7),
    ("?ids=gcs&comp=200", (255, 200), None),
])
def test_the_ids_trimd_sends_from(query: str, source: tuple[int, int], sysid: int | None
                                  ) -> None:
    o = parse_mavlink_url("udpin:127.0.0.1:0" + query, default_timeout_s=3)
    assert o.source == source and o.sysid == sysid and o.announce


@pytest.mark.parametrize(("query", "message"), [
    ("ids=robot", "ids='robot': expected one of gcs, vehicle"),
    ("comp=0", "comp='0': expected an integer 1..255"),
    ("announce=maybe", "announce='maybe': expected one of on, off"),
    ("ids=vehicle&pilot=always", "ArduSub takes pilot input only from its ground station"),
])
def test_bad_ids_options_are_link_errors(query: str, message: str) -> None:
    with pytest.raises(LinkError, match=message):
        parse_mavlink_url("udpin:127.0.0.1:0?" + query, default_timeout_s=3)
    assert not parse_mavlink_url("udpin:127.0.0.1:0?announce=off",
                                 default_timeout_s=3).announce


# ------------------------------------------------------------------ a live watch
class OneAlertWatch(TrimWatch):
    """A watch whose first attitude sample after the vehicle appeared completes a
    segment and raises an alert (so the test need not wait for real segments)."""

    done = False
    connected = False

    def feed(self, s: Sample) -> list[WatchSegment | WatchAlert]:
        self.connected |= isinstance(s, Health) and s.connected
        if self.done or not (self.connected and isinstance(s, Attitude)):
            return []
        self.done = True
        q = np.array([2.5, 0.01, -0.02, 0.0])
        est = SegmentEstimate("segment 1", s.t_s - 60, s.t_s, 0.0, 0.0, 600, q,
                              np.eye(4) * 1e-4, np.eye(4) * 1e-4, np.zeros((4, 16)),
                              (True, True, True, False), True)
        alert = ChangeAlert(0, 2.4, 0.1, 2.4, 0.1, math.nan, s.t_s - 300, s.t_s, 2, 9.0, True)
        return [WatchSegment(1, est, baseline=False), WatchAlert(alert, "heavier")]


#: What a watch may send, and the one command it sends (the stream rates it reads).
WATCH_SENDS = {"HEARTBEAT", "COMMAND_LONG", "PARAM_REQUEST_READ", "STATUSTEXT",
               "NAMED_VALUE_FLOAT"}


@pytest.mark.parametrize(("ids", "source", "beat_type"), [
    ("gcs", (255, 190), mavlink2.MAV_TYPE_GCS),
    ("vehicle", (1, 191), mavlink2.MAV_TYPE_ONBOARD_CONTROLLER),
])
def test_a_watch_sends_exactly_heartbeat_stream_and_parameter_requests_texts_and_values(
        bluerov: Profile, ids: str, source: tuple[int, int], beat_type: int) -> None:
    """The simulator behind its router passes everything trimd sends to a second
    endpoint, where the test listens: nothing but the set the watch may send, with the
    URL's ids, until the alert, the values and every stream request have gone out."""
    port, sniff_port = free_udp_port(), free_udp_port()
    sniffer = open_mavlink2(f"udpin:127.0.0.1:{sniff_port}", 254, 1)
    link = asyncio.run(open_link(f"mavlink:udpin:127.0.0.1:{port}?ids={ids}", bluerov))
    vehicle = SimVehicle(bluerov, SimConfig(armed=True, mode="ALT_HOLD", seed=1))
    server = MavlinkServer(vehicle, [f"udpout:127.0.0.1:{port}",
                                     f"udpout:127.0.0.1:{sniff_port}"], rate=2.0)
    server_stop = threading.Event()
    thread = threading.Thread(target=server.run, args=(server_stop,), daemon=True)
    sent: list[Any] = []

    def heard() -> Counter[str]:
        return Counter(m.get_type() for m in sent)

    def enough() -> bool:
        commands = sum(m.get_type() == "COMMAND_LONG" for m in sent)
        return bool(commands >= 4 and heard()["NAMED_VALUE_FLOAT"] >= 3
                    and heard()["HEARTBEAT"] >= 2
                    and any(m.get_type() == "STATUSTEXT" and m.severity == 1 for m in sent))

    async def go() -> None:
        stop = asyncio.Event()
        task = asyncio.create_task(watch_link(link, OneAlertWatch(bluerov), lambda r: None,
                                              stop=stop))
        deadline = time.monotonic() + WALL_LIMIT_S          # hang guard
        while not enough():
            assert time.monotonic() < deadline, heard()
            while (msg := sniffer.recv_msg()) is not None:
                if (msg.get_srcSystem(), msg.get_srcComponent()) == source:
                    sent.append(msg)
            await asyncio.sleep(0.02)
        stop.set()
        await task

    thread.start()
    try:
        asyncio.run(go())
    finally:
        server_stop.set()
        thread.join(timeout=5)
        asyncio.run(link.close())
        sniffer.close()
    assert set(heard()) == WATCH_SENDS, heard()
    assert {m.command for m in sent if m.get_type() == "COMMAND_LONG"} == {
        mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL}
    assert {m.type for m in sent if m.get_type() == "HEARTBEAT"} == {beat_type}
    texts = joined(sent)
    assert (1, "TRIMD heavier 2.4+-0.1N since 5min: water?") in texts, texts
    assert (6, "TRIMD watch on: baseline after 3 hovers") in texts, texts
    values = {m.name: round(m.value, 3) for m in sent if m.get_type() == "NAMED_VALUE_FLOAT"}
    assert values == {"TRIMD_WB": 2.5, "TRIMD_MX": 0.01, "TRIMD_MY": -0.02}


# ------------------------------------------------------------------ ids=vehicle commands
@pytest.mark.parametrize(("query", "sticks"), [("", True), ("?ids=vehicle", False)])
def test_as_a_component_of_the_vehicle_trimd_sends_no_sticks(
        bluerov: Profile, query: str, sticks: bool) -> None:
    """Alone, a hold comes with neutral MANUAL_CONTROL from trimd's own ids; as a component
    of the vehicle none (ArduSub takes sticks only from SYSID_MYGCS), and open-loop input
    is refused with the reason."""
    options = parse_mavlink_url("udpin:127.0.0.1:0" + query, default_timeout_s=3)
    wire = Wire()
    mav = mavlink2.MAVLink(wire, srcSystem=options.source[0], srcComponent=options.source[1])
    decoder = MavlinkDecoder.for_profile(bluerov, sysid=options.sysid)
    beat = mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_SUBMARINE,
                                              mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                              mavlink2.MAV_MODE_FLAG_SAFETY_ARMED, 2, 4, 3)
    beat.pack(mavlink2.MAVLink(None, srcSystem=1, srcComponent=1))
    decoder.decode(beat, 0.0)
    commander = Commander(mav, bluerov, decoder, options, lambda text: None,
                          Stations(options.source))
    hold: Future[None] = Future()
    commander.apply(HoldAttitude(0.0, 0.1, 0.0), 0.0, hold)
    for t in np.arange(0.0, 1.0, 0.05):
        commander.tick(float(t))
    kinds = Counter(m.get_type() for m in wire.messages())
    assert kinds["SET_ATTITUDE_TARGET"] >= 4
    assert (kinds["MANUAL_CONTROL"] > 0) is sticks, kinds
    commander.release(1.0)
    open_loop: Future[None] = Future()
    commander.apply(OpenLoop((0.1, 0, 0, 0, 0, 0)), 1.0, open_loop)
    if sticks:
        assert not open_loop.done()          # waits for the vehicle's mode change
    else:
        with pytest.raises(LinkError, match="with ids=vehicle it is none"):
            open_loop.result(timeout=0)
