"""The serial driver: on pyserial's ``loop://``, and end to end against the simulated vehicle
served over a real pseudo-terminal (in a thread, and as ``trimd sim`` in a subprocess).

Rates and holds are judged on the samples' own stamps (the vehicle's clock on the
``time.monotonic()`` base), link-lost as no earlier than its timeout and by its cause;
wall-clock limits only keep a broken link from hanging the suite (how soon something
happens on the wall clock depends on the machine's load: never asserted).
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import re
import select
import subprocess
import sys
import threading
import time
import tty
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import trimd.app.connect
from tests.helpers import REPO, assert_proposal_levels
from trimd.app.connect import open_link
from trimd.cli.main import main
from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.samples import (
    Attitude,
    Health,
    HoldAttitude,
    PilotInput,
    Release,
    Sample,
    VehicleText,
)
from trimd.drivers.serial.link import (
    NOT_TAKEN_AFTER,
    NOT_TAKEN_S,
    SerialLink,
    open_serial_link,
)
from trimd.drivers.serial.protocol import (
    BAD_COUNTERS,
    MAX_LINE_BYTES,
    VEHICLE,
    LineParser,
    checksum,
    to_sample,
)
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.pacing import run_paced
from trimd.drivers.sim.serial_server import COMMAND_TIMEOUT_S, SerialServer
from trimd.drivers.sim.vehicle import SimVehicle

RATE = 10.0            # simulated seconds per wall second of the threaded server
WALL_LIMIT_S = 30.0    # a hang guard, not a timed assertion
DEG = math.pi / 180


def frame(body: str) -> bytes:
    return b"$%s*%02X\r\n" % (body.encode(), checksum(body.encode()))


async def collect(link: SerialLink, until: object, limit_s: float = WALL_LIMIT_S
                  ) -> list[Sample]:
    """Samples until ``until(sample)`` is true (that one included)."""
    out: list[Sample] = []

    async def go() -> None:
        async for s in link.samples():
            out.append(s)
            if until(s):  # type: ignore[operator]
                return
    await asyncio.wait_for(go(), limit_s)
    return out


async def until(condition: Callable[[], bool]) -> None:
    """Returns once ``condition()`` holds (callers bound it with a hang guard)."""
    while not condition():
        await asyncio.sleep(0.01)


# ---------------------------------------------------------------------- loop://
def test_url_forms(sabertooth: Profile) -> None:
    for url in ("loop://", "loop://,9600"):
        link = open_serial_link(url, sabertooth)
        assert link.port.baudrate == (9600 if url.endswith("9600") else 115_200)
        asyncio.run(link.close())
    with pytest.raises(LinkError, match="needs a device"):
        open_serial_link(",9600", sabertooth)
    with pytest.raises(LinkError, match="baud rate must be a positive integer, got 'fast'"):
        open_serial_link("loop://,fast", sabertooth)
    with pytest.raises(LinkError, match="cannot open serial /nonexistent/tty"):
        open_serial_link("/nonexistent/tty", sabertooth)


def test_handshake_vehicle_clock_and_silence_on_loop(sabertooth: Profile) -> None:
    async def go() -> None:
        link = open_serial_link("loop://", sabertooth, timeout_s=0.3)
        write = link.port.write
        write(frame("VHSTA,1000,MANUAL,0,PILOT"))
        (h,) = await collect(link, lambda s: True)
        assert isinstance(h, Health) and not h.connected and "VHVER" in h.detail
        with pytest.raises(LinkError, match="version sentence"):
            await link.send(HoldAttitude(0.0, 0.0, 0.0))
        write(frame("VHVER,1,bench") + frame("VHSTA,2000,ALT_HOLD,1,PILOT"))
        (h,) = await collect(link, lambda s: True)
        assert isinstance(h, Health) and h.connected and h.mode == "ALT_HOLD" and h.armed
        assert h.vehicle == "bench"
        write(frame("VHTXT,2100,4,Leak sensor dry"))
        (text,) = await collect(link, lambda s: True)
        assert isinstance(text, VehicleText) and (text.severity, text.text) == (
            4, "Leak sensor dry")
        # the vehicle clock: across the uint32 wrap, 50 ms back, set 99.85 s on (a time
        # sync: one usual step), then a reboot
        for t_ms in (2**32 - 300, 200, 150, 100_000, 5):
            write(frame(f"VHATT,{t_ms},1,2,3,4,5,6"))
        got = [s for _ in range(5) for s in await collect(link, lambda s: True)]
        stamps = [s.t_s for s in got]
        assert len(stamps) == 5
        assert stamps[1] - stamps[0] == pytest.approx(0.5, abs=1e-9)
        assert stamps[2] - stamps[1] == pytest.approx(-0.05, abs=1e-9)
        assert stamps[3] - stamps[2] == pytest.approx(0.5, abs=1e-9)
        # re-anchored on the reboot (not 99.85 s on); the bound only allows for a slow thread
        assert abs(stamps[4] - time.monotonic()) < 10.0
        # silence: the link's own TR lines come back on loop:// but are not the vehicle
        (lost,) = await collect(link, lambda s: isinstance(s, Health))
        assert isinstance(lost, Health) and not lost.connected
        assert "no data from the vehicle" in lost.detail
        assert lost.t_s - stamps[4] >= 0.3            # not before the timeout
        assert link.parser.counts["unknown"] >= 1 and link.parser.counts["ok"] == 9
        assert lost.bad_frames == link.parser.bad_lines
        write(frame("VHVER,2,future"))
        # another version ends the link: a disconnected Health, then the reason
        with pytest.raises(LinkError, match=r"^the vehicle \(future\) speaks serial protocol "
                           r"version 2, trimd speaks 1$"):
            await collect(link, lambda s: False)
        assert link.vehicle is None
        with pytest.raises(LinkError, match="speaks serial protocol version 2"):
            await link.send(HoldAttitude(0.0, 0.0, 0.0))
        await link.close()
        with pytest.raises(LinkError, match="closed"):
            await link.send(Release())
    asyncio.run(go())


def test_loss_stops_the_hold_and_holds_beyond_the_tilt_limit_are_refused(
        sabertooth: Profile) -> None:
    """After a loss trimd repeats no command (one must come again, as over MAVLink); a
    hold beyond max_tilt_deg never leaves trimd. The test plays the vehicle on a pty."""
    master, slave = os.openpty()
    tty.setraw(master)
    received = b""

    def heard(until: Callable[[bytes], bool], *, talking: bool = False) -> bytes:
        """What trimd wrote to the vehicle until ``until(what)`` holds (the vehicle
        sending its status every 50 ms when ``talking``; hang guard only)."""
        nonlocal received
        start, got = time.monotonic(), b""
        while not until(got):
            assert time.monotonic() < start + WALL_LIMIT_S, got[-200:]
            if talking:
                t_ms = 1000 + round((time.monotonic() - start) * 1000)
                os.write(master, frame(f"VHSTA,{t_ms},ALT_HOLD,1,HOLD"))
            if select.select([master], [], [], 0.05)[0]:
                got += os.read(master, 4096)
        received += got
        return got

    def lines(got: bytes, start: bytes) -> int:
        """Whole sentences in ``got`` that start with ``start``."""
        return sum(line.startswith(start) for line in got.split(b"\n")[:-1])

    async def go() -> None:
        link = open_serial_link(os.ttyname(slave), sabertooth, timeout_s=0.3)
        os.write(master, frame("VHVER,1,bench") + frame("VHSTA,1000,ALT_HOLD,1,HOLD"))
        await collect(link, lambda s: isinstance(s, Health) and s.connected)
        with pytest.raises(LinkError, match=r"roll 30\.0°.*beyond the profile's max_tilt"):
            await link.send(HoldAttitude(30 * DEG, 0.0, 0.0))
        await link.send(HoldAttitude(10 * DEG, 5 * DEG, 0.0))
        heard(lambda got: lines(got, b"$TRHLD,10.000,5.000") >= 2, talking=True)  # repeated
        await collect(link, lambda s: isinstance(s, Health) and not s.connected)
        # the vehicle silent, trimd lost it: from the next whole sentence on, heartbeats
        # only (a hold sentence may have been under way)
        heard(lambda got: got.endswith(b"\n"))
        after = heard(lambda got: lines(got, b"$TRHBT") >= 2)
        assert b"TRHLD" not in after
        await link.close()

    try:
        asyncio.run(go())
    finally:
        os.close(master)
        os.close(slave)
    assert b"30.000" not in received


# ---------------------------------------------------------------------- a real pty
@pytest.fixture()
def served(sabertooth: Profile) -> Iterator[tuple[SerialServer, threading.Event]]:
    vehicle = SimVehicle(sabertooth, SimConfig(payload="10@AftSB", seed=4))  # armed, ALT_HOLD
    server = SerialServer(vehicle, rate=RATE)
    stop = threading.Event()
    thread = threading.Thread(target=server.run, args=(stop,), daemon=True)
    thread.start()
    yield server, stop
    stop.set()
    thread.join(timeout=5)


def rates(samples: list[Sample]) -> dict[str, float]:
    """Samples of each type per second of the samples' own time."""
    span = samples[-1].t_s - samples[0].t_s
    return {k: n / span for k, n in Counter(type(s).__name__ for s in samples).items()}


def test_served_vehicle_rates_hold_release_and_link_lost(
        served: tuple[SerialServer, threading.Event], sabertooth: Profile) -> None:
    server, stop = served
    vehicle = server.vehicle

    async def go() -> None:
        link = await open_link(f"serial:{server.path}", sabertooth)
        assert isinstance(link, SerialLink)
        t0 = (await collect(link, lambda s: isinstance(s, Health) and s.connected))[-1].t_s
        quiet = await collect(link, lambda s: s.t_s > t0 + 20.0)
        r = rates(quiet)
        assert r["Attitude"] == pytest.approx(20.0, rel=0.05)
        assert r["Thrusters"] == pytest.approx(10.0, rel=0.05)
        assert r["Depth"] == pytest.approx(5.0, rel=0.05)
        assert r["Health"] == pytest.approx(1.0, rel=0.15)
        assert r["Battery"] == pytest.approx(1.0, rel=0.15)
        assert all(len(s.pwm_us) == 6 for s in quiet if hasattr(s, "pwm_us"))

        # a hold held for 40 s of vehicle time (4 s of wall time: kept alive by the
        # control sentence, or the vehicle would release after 1.5 s)
        target = (10 * DEG, -5 * DEG, 0.3)
        await link.send(HoldAttitude(*target))
        held = await collect(link, lambda s: s.t_s > t0 + 60.0)
        assert server.control == "HOLD"
        assert [h.detail for h in held if isinstance(h, Health)][-1] == "control HOLD"
        assert not any(isinstance(s, PilotInput) for s in held)   # trimd flies it
        att = [s for s in held if isinstance(s, Attitude)][-40:]
        for got, want in zip(np.mean([(a.phi, a.theta, a.psi) for a in att], axis=0), target,
                             strict=True):
            assert abs(got - want) < 0.3 * DEG
        np.testing.assert_allclose(vehicle.truth.eta[3:], target, atol=0.3 * DEG)

        await link.send(Release())
        released = await collect(link, lambda s: s.t_s > t0 + 90.0)
        assert server.control == "PILOT" and vehicle.mode == "ALT_HOLD"
        att = [s for s in released if isinstance(s, Attitude)][-20:]
        assert max(abs(a.phi) + abs(a.theta) for a in att) < 0.5 * DEG

        # the vehicle goes away (the server closes the pty): link-lost on the samples' own
        # clock, from the device's end, not a silence timeout
        stop.set()
        gone = released + await collect(link, lambda s: isinstance(s, Health)
                                        and not s.connected)
        lost_after = gone[-1].t_s - gone[-2].t_s
        print(f"link lost {lost_after * 1000:.1f} ms after the last sentence: "
              f"{gone[-1].detail}")
        assert lost_after >= 0 and "no data from the vehicle" not in gone[-1].detail
        assert gone[-1].detail.startswith(f"{link.description}: "), gone[-1].detail
        assert link.parser.bad_lines == 0 and server.parser.bad_lines == 0
        await link.close()
    asyncio.run(go())


def test_vehicle_releases_when_trimd_falls_silent_and_trimd_sees_silence(
        sabertooth: Profile) -> None:
    server = SerialServer(SimVehicle(sabertooth, SimConfig(seed=5)), rate=RATE)
    pause = threading.Event()
    thread = threading.Thread(target=run_paced, args=(server.vehicle, server.advance_to,
                                                      server.master),
                              kwargs={"rate": RATE, "stop": pause}, daemon=True)
    thread.start()

    # trimd falls silent after one hold sentence: the vehicle releases by itself
    trimd = os.open(server.path, os.O_RDWR | os.O_NOCTTY)
    os.write(trimd, frame("TRHLD,5.000,0,0"))
    t_quiet = time.monotonic()
    while server.control != "HOLD" and time.monotonic() - t_quiet < WALL_LIMIT_S:
        time.sleep(0.01)
    assert server.control == "HOLD"
    while server.control != "PILOT" and time.monotonic() - t_quiet < WALL_LIMIT_S:
        time.sleep(0.05)
    quiet_s = time.monotonic() - t_quiet
    os.close(trimd)
    print(f"vehicle released {quiet_s:.2f} s after trimd fell silent")
    assert server.control == "PILOT" and quiet_s >= COMMAND_TIMEOUT_S

    async def go() -> None:
        # the vehicle falls silent without closing the device: trimd sees the silence
        link = open_serial_link(server.path, sabertooth, timeout_s=0.5)
        before = await collect(link, lambda s: isinstance(s, Health) and s.connected)
        pause.set()
        got = before + await collect(link, lambda s: isinstance(s, Health) and not s.connected)
        silent = got[-1].t_s - got[-2].t_s
        print(f"link lost {silent:.3f} s after the vehicle's last sentence (timeout 0.5 s)")
        assert silent >= 0.5 and "no data from the vehicle for" in got[-1].detail
        await link.close()
    try:
        asyncio.run(go())
    finally:
        pause.set()
        thread.join(timeout=5)
        server.close()


def test_the_served_vehicle_says_why_it_released(sabertooth: Profile) -> None:
    server = SerialServer(SimVehicle(sabertooth, SimConfig(seed=5)))
    trimd = os.open(server.path, os.O_RDWR | os.O_NOCTTY)
    try:
        os.read(trimd, 4096)  # the boot VHVER
        server.handle(HoldAttitude(5 * DEG, 0.0, 0.0))
        server._heard = time.monotonic() - COMMAND_TIMEOUT_S - 0.1  # trimd fell silent
        server.poll()
        assert server.control == "PILOT"
        parser = LineParser(VEHICLE)
        [said] = parser.feed(os.read(trimd, 4096))
        assert to_sample(said, 0.0, ()) == VehicleText(
            0.0, 4, "trimd silent for 1.5 s: control back to the pilot")
    finally:
        os.close(trimd)
        server.close()


def test_the_pilot_taking_over_mid_hold_is_a_pilot_input_and_holds_no_longer_take_it(
        served: tuple[SerialServer, threading.Event], sabertooth: Profile) -> None:
    server, _ = served

    async def go() -> None:
        link = await open_link(f"serial:{server.path}", sabertooth)
        assert isinstance(link, SerialLink)
        await collect(link, lambda s: isinstance(s, Health) and s.connected)
        await link.send(HoldAttitude(5 * DEG, 0.0, 0.3))
        await collect(link, lambda s: isinstance(s, Health) and s.detail == "control HOLD")
        server.pilot_takes_over("MANUAL")
        got = await collect(link, lambda s: isinstance(s, PilotInput))
        assert got[-1].source == "the vehicle reports control PILOT, mode MANUAL"
        hold_sentences = server.heard["HLD"]
        # trimd's link still repeats the hold (until the procedure releases): the vehicle
        # ignores it, the pilot keeps the vehicle
        await asyncio.wait_for(until(lambda: server.heard["HLD"] >= hold_sentences + 2),
                               WALL_LIMIT_S)
        assert server.control == "PILOT" and server.vehicle.mode == "MANUAL"
        assert server.pilot_latched
        await link.send(Release())
        await asyncio.wait_for(until(lambda: not server.pilot_latched), WALL_LIMIT_S)
        assert server.heard["REL"] == 1
        later = await collect(link, lambda s: isinstance(s, Health))
        assert not any(isinstance(s, PilotInput) for s in later)  # said once
        await link.close()
    asyncio.run(go())


def test_the_simulated_pilot_takes_over_only_in_a_mode_the_simulator_flies(
        sabertooth: Profile) -> None:
    server = SerialServer(SimVehicle(sabertooth, SimConfig(seed=5)))
    try:
        with pytest.raises(ValueError, match="not SURFACE"):
            server.pilot_takes_over("SURFACE")
    finally:
        server.close()


class PtyVehicle:
    """A vehicle of our own on a pseudo-terminal: streams attitude (and, with ``status``,
    VHSTA) every 50 ms of its clock and answers trimd's TRVER with ``VHVER,<answer>`` (or
    never: None)."""

    def __init__(self, answer: str | None, *, status: bool = True) -> None:
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.answer = answer
        self.status = status
        self.heard = b""
        self.stop = threading.Event()

    def run(self) -> None:
        t_ms = 0
        try:
            while not self.stop.is_set():
                if select.select([self.master], [], [], 0.05)[0]:
                    data = os.read(self.master, 4096)
                    self.heard += data
                    if b"$TRVER" in data and self.answer is not None:
                        os.write(self.master, frame(f"VHVER,{self.answer}"))
                t_ms += 50
                os.write(self.master, frame(f"VHATT,{t_ms},0,0,0,0,0,0") + (
                    frame(f"VHSTA,{t_ms},ALT_HOLD,1,PILOT") if self.status else b""))
        except OSError:
            pass   # trimd closed its side
        finally:
            os.close(self.master)
            os.close(self._slave)


def test_a_vehicle_that_never_takes_trimd_s_hold_is_flown_by_its_pilot(
        sabertooth: Profile) -> None:
    """Its status (20 a second) always says control PILOT: after NOT_TAKEN_AFTER of them
    and NOT_TAKEN_S of wall clock since the command, not before (a vehicle, or a simulator
    faster than real time, sending status faster than a loaded machine delivers the
    command is not taken for one that refused it), one PilotInput says so."""
    vehicle = PtyVehicle("1,bench")
    thread = threading.Thread(target=vehicle.run, daemon=True)
    thread.start()

    async def go() -> None:
        link = open_serial_link(vehicle.path, sabertooth)
        await collect(link, lambda s: isinstance(s, Health) and s.connected)
        sent = time.monotonic()
        await link.send(HoldAttitude(5 * DEG, 0.0, 0.0))
        got = await collect(link, lambda s: isinstance(s, PilotInput))
        assert time.monotonic() - sent >= NOT_TAKEN_S   # not before (a bound load cannot break)
        said = re.fullmatch(r"the vehicle did not take trimd's command: control PILOT in "
                            r"(\d+) status sentences, mode ALT_HOLD", got[-1].source)
        assert said and int(said[1]) >= NOT_TAKEN_AFTER, got[-1].source
        statuses = [s for s in got if isinstance(s, Health)]
        assert len(statuses) >= int(said[1])        # not before that many said so
        more = await collect(link, lambda s: isinstance(s, Health) and s.t_s > got[-1].t_s
                             + 0.5)
        assert not any(isinstance(s, PilotInput) for s in more)   # said once
        await link.close()
    try:
        asyncio.run(go())
    finally:
        vehicle.stop.set()
        thread.join(timeout=5)


MUTE = ("the vehicle did not connect within 2 s: the vehicle sends telemetry but has not "
        "answered trimd's version sentence (TRVER) with VHVER")


@pytest.mark.parametrize(("answer", "status", "reason"), [
    ("2,old", True, "the vehicle (old) speaks serial protocol version 2, trimd speaks 1"),
    (None, True, MUTE),
    (None, False, MUTE),      # no VHSTA either: its attitude says it is there
])
def test_trimd_run_against_a_vehicle_of_another_version_or_one_that_never_answers_exits_3(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], answer: str | None,
        status: bool, reason: str) -> None:
    """Through a real pseudo-terminal: a version-2 vehicle fails at once, a mute one
    after connect_timeout_s (2 s here); either way with the reason, exit 3, nothing
    commanded."""
    profile = tmp_path / "quick.yaml"
    text = (REPO / "trimd" / "profiles" / "sabertooth-dh2.yaml").read_text(encoding="utf-8")
    assert "connect_timeout_s: 30.0" in text
    profile.write_text(text.replace("connect_timeout_s: 30.0", "connect_timeout_s: 2.0"),
                       encoding="utf-8")
    vehicle = PtyVehicle(answer, status=status)
    thread = threading.Thread(target=vehicle.run, daemon=True)
    thread.start()
    start = time.monotonic()
    try:
        code = main(["run", "--link", f"serial:{vehicle.path}", "--profile", str(profile),
                     "--headless", "--yes", "--no-record"])
    finally:
        vehicle.stop.set()
        thread.join(timeout=5)
    took = time.monotonic() - start
    err = capsys.readouterr().err
    with capsys.disabled():
        print(f"failed after {took:.2f} s of wall time (connect_timeout_s 2)")
    assert code == 3, err
    assert f"trimd: failed: link lost: {reason}" in err
    assert b"$TRVER,1,trimd" in vehicle.heard
    assert not re.search(rb"\$TR(HLD|OPN|ARM)", vehicle.heard)   # nothing commanded
    if answer is None:
        assert took >= 2.0        # not before the timeout (a lower bound, not a timing)


@pytest.mark.slow
def test_trimd_run_ends_with_exit_1_when_the_pilot_takes_over_mid_hold(
        served: tuple[SerialServer, threading.Event], capsys: pytest.CaptureFixture[str],
        tmp_path: Path) -> None:
    """The pilot switches the vehicle to MANUAL during the first hold: trimd releases
    at once, exits 1 with the reason and makes no estimate; the replay of its log ends
    the same way."""
    server, _ = served
    done = threading.Event()

    def pilot() -> None:
        while server.control != "HOLD" and not done.wait(0.01):
            pass
        t_hold = server.vehicle.t_s
        while server.vehicle.t_s < t_hold + 5.0 and not done.wait(0.01):
            pass
        server.pilot_takes_over("MANUAL")
    watcher = threading.Thread(target=pilot, daemon=True)
    watcher.start()
    try:
        code = main(["run", "--link", f"serial:{server.path}", "--profile", "sabertooth-dh2",
                     "--headless", "--yes", "--record", str(tmp_path / "s.tlog"), "--json"])
    finally:
        done.set()
        watcher.join(timeout=5)
    captured = capsys.readouterr()
    assert code == 1, captured.err
    said = ("the pilot took over (the vehicle reports control PILOT, mode MANUAL): trimd "
            "released control")
    assert f"trimd: failed: {said}" in captured.err
    lines = [json.loads(x) for x in captured.out.splitlines()]
    assert "result" not in {x["type"] for x in lines}
    commands = [x for x in lines if x["type"] == "command"]
    assert commands[-1]["command"].startswith("release")
    assert server.heard["REL"] >= 1 and not server.pilot_latched
    assert server.control == "PILOT" and server.vehicle.mode == "MANUAL"
    assert main(["replay", str(tmp_path / "s.tlog"), "--json"]) == 1
    replayed = capsys.readouterr()
    assert said in replayed.err
    assert "result" not in {json.loads(x)["type"] for x in replayed.out.splitlines()}


# ---------------------------------------------------------------------- trimd run
class Relay:
    """A man in the middle between ``trimd sim``'s pseudo-terminal and trimd, on a
    pseudo-terminal of its own: forwards both ways, and once trimd has spoken replaces
    every 10th vehicle line with a bad one, ``count`` times (``injected`` by counter)."""

    def __init__(self, vehicle_path: str, count: int, stop: threading.Event) -> None:
        self.vehicle = os.open(vehicle_path, os.O_RDWR | os.O_NOCTTY)
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.count = count
        self.injected: Counter[str] = Counter()
        self.stop = stop
        self._lines = 0

    def run(self) -> None:
        """Relay until ``stop`` is set or a side closes (an empty read: end of file, which
        select reports ready for ever: two relays left spinning on it used 0.7 s of CPU
        per 0.5 s of wall in their test worker for the rest of the run)."""
        buffer, heard = b"", False
        try:
            while not self.stop.is_set():
                ready, _, _ = select.select([self.vehicle, self.master], [], [], 0.1)
                if self.master in ready:
                    data = os.read(self.master, 4096)
                    if not data:
                        break
                    os.write(self.vehicle, data)
                    heard = True
                if self.vehicle in ready:
                    data = os.read(self.vehicle, 65536)
                    if not data:
                        break
                    buffer += data
                    *lines, buffer = buffer.split(b"\n")
                    if heard:
                        os.write(self.master, b"".join(self._mangle(x + b"\n") for x in lines))
        except OSError:
            pass        # the simulator or the test closed a side
        finally:
            for fd in (self.vehicle, self.master, self._slave):
                os.close(fd)

    def _mangle(self, line: bytes) -> bytes:
        self._lines += 1
        if self._lines % 10 or sum(self.injected.values()) >= self.count:
            return line
        kind = BAD_COUNTERS[sum(self.injected.values()) % len(BAD_COUNTERS)]
        self.injected[kind] += 1
        return {"too_long": b"$VHDPT," + b"9" * MAX_LINE_BYTES + b"\r\n",
                "malformed": b"\x00\xffnoise on the line\r\n",
                "bad_checksum": line[:-4] + b"%02X\r\n" % (int(line[-4:-2], 16) ^ 0x21),
                "unknown": frame("VHXYZ,1,2"),
                "bad_fields": frame("VHDPT,1"),
                "bad_value": frame("VHDPT,1,nan")}[kind]


@pytest.mark.slow
@pytest.mark.parametrize("payload", ["10@AftSB", "6@0.5,-0.45,0.25"])   # one above the CO
def test_trimd_run_over_serial_against_trimd_sim(
        sabertooth: Profile, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str], payload: str) -> None:
    sim = subprocess.Popen(
        [sys.executable, "-m", "trimd", "sim", "--profile", "sabertooth-dh2",
         "--payload", payload, "--serve", "serial:pty", "--rate", "20",
         "--options", "armed=1,mode=ALT_HOLD"], stdout=subprocess.PIPE, text=True,
        cwd=REPO)
    stop_relay, relaying = threading.Event(), None
    try:
        assert sim.stdout is not None
        banner = sim.stdout.readline()
        match = re.search(r" on (/dev/\S+) at 20× real time", banner)
        assert match, banner
        relay = Relay(match.group(1), count=120, stop=stop_relay)
        relaying = threading.Thread(target=relay.run, daemon=True)
        relaying.start()
        links: list[SerialLink] = []

        async def capture(url: str, profile: Profile) -> object:
            link = await open_link(url, profile)
            links.append(link)  # type: ignore[arg-type]
            return link
        monkeypatch.setattr(trimd.app.connect, "open_link", capture)
        code = main(["run", "--link", f"serial:{relay.path}", "--profile", "sabertooth-dh2",
                     "--headless", "--yes", "--no-record", "--json"])
    finally:
        sim.terminate()
        sim.wait(timeout=10)
        stop_relay.set()
        if relaying is not None:
            relaying.join(timeout=10)
            assert not relaying.is_alive(), "the relay did not stop"
    out = capsys.readouterr().out.splitlines()
    assert code == 0, out[-3:]
    result = json.loads(out[-1])
    truth = SimVehicle(sabertooth, SimConfig(payload=payload)).truth
    err = np.asarray(result["estimate"]["cg_m"]) - truth.mass.r_g
    m_err = result["estimate"]["m_ext_kg"] - truth.m_ext_kg
    print(f"serial trim: r_g error {np.round(err * 1000, 4)} mm, m_ext error {m_err:+.3f} kg")
    assert np.all(np.abs(err[:2]) < 1e-3) and abs(err[2]) < 3e-3, err
    # within its own 95 % interval (it carries the thrust curves' 5 %: ≈ ±1 kg)
    assert abs(m_err) < 1.96 * result["estimate"]["m_ext_std_kg"]
    assert_proposal_levels(sabertooth, payload, result["proposal"])  # milp, applied
    # every injected bad line counted under its own name, nothing else dropped
    counts = links[0].parser.counts
    assert sum(relay.injected.values()) == 120
    assert {k: counts[k] for k in BAD_COUNTERS} == dict(relay.injected)


def test_a_vehicle_clock_set_forward_does_not_skip_time() -> None:
    """A time sync moves the vehicle clock +400 s mid-hold: the samples go on at their
    usual spacing (a hold is not cut short by 400 s it did not live through); a reboot
    (the clock back to 0) re-anchors on the time of receipt."""
    from trimd.drivers.serial.link import _VehicleClock

    clock = _VehicleClock()
    stamps = [clock.stamp(t_ms, 100.0 + k * 0.1) for k, t_ms in enumerate(
        [1000, 1100, 1200, 1300, 401_400, 401_500])]
    assert np.allclose(np.diff(stamps), 0.1)
    assert clock.stamp(5, 200.0) == 200.0
