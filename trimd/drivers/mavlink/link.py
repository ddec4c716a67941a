"""The live MAVLink link (``--link mavlink:…``): an ArduSub vehicle through pymavlink.

One I/O thread owns the pymavlink connection (blocking I/O in its own thread, as MAVProxy
does). It reads and decodes every packet
(:class:`~trimd.drivers.mavlink.decode.MavlinkDecoder`), stamps it with ``time.monotonic()``
on receipt, and runs the :class:`~trimd.drivers.mavlink.commands.Commander`, which sends
the stream and parameter requests and the periodic hold / pilot messages, so a busy event
loop can never starve ArduSub's 5 s attitude-target and 3 s pilot-input timeouts, and the
:class:`~trimd.drivers.mavlink.outbox.Outbox`: trimd's heartbeat and what
:meth:`MavlinkLink.announce` queues (STATUSTEXT, NAMED_VALUE_FLOAT, within a budget).
The asyncio side sees a bounded queue of samples (the oldest are dropped and counted when
the consumer falls behind; a backlog lets the event loop run every 200 samples).

The protocol is pinned: MAVLink 2 and pymavlink's generated ``v20.ardupilotmega`` dialect
from the first byte, whatever ``MAVLINK20`` says. The vehicle is the one the URL's
``sysid`` names, else the first autopilot heartbeat that is not a GCS; mode and armed state
come from that component only; other systems are ignored (counted by the decoder),
except other ground stations' HEARTBEAT and MANUAL_CONTROL
(:mod:`~trimd.drivers.mavlink.stations`): beside another station trimd sends no
MANUAL_CONTROL, and while trimd commands, that station's sticks beyond neutral or a mode
change trimd did not ask for make trimd stop commanding at once and yield a
:class:`~trimd.core.samples.PilotInput` sample (the procedure then ends, exit 1).

Health samples: every vehicle HEARTBEAT yields ``Health(connected=True, …)`` whose
``bad_frames`` is this link's count and whose ``detail`` lists the warnings so far
(stream-request fallbacks, parameters that disagree with the profile, other ground stations
and whether trimd sends pilot input; each is also logged once on the
``trimd.drivers.mavlink.link`` logger). No heartbeat for the URL's ``timeout``
yields one ``Health(connected=False, detail=…)`` (the link may come back: the next heartbeat yields
``connected=True`` again, and commanding has to be asked for again). A transport that
fails (serial device gone, TCP closed by the peer) yields the same, and then the sample
iterator raises :class:`LinkError`.

Raw packets: set :attr:`MavlinkLink.on_raw` to ``callback(t_s, packet)`` to receive every
good packet as it came off the wire (signature included), with its receipt time on the
samples' clock, in the event loop's thread, just before the samples it carries; e.g.
``TlogRecorder.raw`` after converting ``t_s`` to the recorder's time base.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
import queue
import socket
import threading
import time
from collections import Counter, deque
from collections.abc import AsyncIterator, Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.announce import Announcement
from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.samples import Command, Health, PilotInput, Release, Sample
from trimd.drivers.limits import check_command
from trimd.drivers.mavlink.commands import Commander
from trimd.drivers.mavlink.decode import MavlinkDecoder, VehicleParams
from trimd.drivers.mavlink.message import MavConnection, MavMessage, speak_mavlink2
from trimd.drivers.mavlink.outbox import Outbox
from trimd.drivers.mavlink.stations import STATION_TIMEOUT_S, Stations
from trimd.drivers.mavlink.url import MavlinkOptions, load_signing_key, parse_mavlink_url

__all__ = ["LinkStats", "MavlinkLink", "open_mavlink_link"]

log = logging.getLogger(__name__)

_POLL_S = 0.05              # longest wait of the I/O thread (commands are taken this fast)
_BURST = 200                # messages read before the thread attends to its timers again
_MAX_ITEMS = 4096           # bounded queue towards the event loop
_CLOSE_GRACE_S = 1.5        # close() waits this long for a mode restore to be answered
_ANSWER_GUARD_S = 4.0       # send() gives up after this long (the Commander's 3 s + slack)


@dataclass
class LinkStats:
    """What the link has counted so far (read at any time; updated by the I/O thread)."""

    messages: int = 0       # good packets
    bad_frames: int = 0     # CRC errors, bad lengths, stretches of garbage between packets
    refused: int = 0        # unsigned or badly signed packets refused (signing on)
    dropped: int = 0        # queue items lost because the consumer fell behind
    gaps: Counter[tuple[int, int]] = field(default_factory=Counter)  # missing seq numbers


_Item = tuple[float, bytes | None, list[Sample]]


def _probe_udp(host: str, port: int) -> None:
    """LinkError when another program listens on ``host:port`` (pymavlink binds with
    SO_REUSEADDR and would silently share the port)."""
    if port == 0:
        return
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        probe.bind((host, port))
    except OSError as exc:
        raise LinkError(f"cannot listen on udp {host}:{port}: {exc.strerror or exc} (another "
                        "ground station or trimd holds it?)") from None
    finally:
        probe.close()


def _closed_by_peer() -> None:
    raise ConnectionError("the other end closed the TCP connection")


def _open(options: MavlinkOptions) -> MavConnection:
    """A pymavlink connection speaking MAVLink 2 / ardupilotmega from the first byte."""
    device = options.device
    sysid, compid = options.source
    kwargs: dict[str, Any] = {"source_system": sysid, "source_component": compid,
                              "dialect": "ardupilotmega"}
    if options.serial:
        kwargs["baud"] = options.baud
    elif device.startswith("tcp:"):
        kwargs["retries"] = 0
    elif device.startswith("udpin:"):
        host, port = device[6:].rsplit(":", 1)
        _probe_udp(host, int(port))
    try:
        conn = speak_mavlink2(mavutil.mavlink_connection(device, **kwargs), sysid, compid)
    except (OSError, ValueError) as exc:
        text = getattr(exc, "strerror", None) or str(exc)
        raise LinkError(f"cannot open mavlink:{device}: {text}") from None
    if device.startswith("tcp:"):  # pymavlink would print and spin on a closed socket
        conn.handle_eof = conn.handle_disconnect = _closed_by_peer
    if options.key_path is not None:
        conn.setup_signing(load_signing_key(options.key_path), sign_outgoing=True)
    return conn


class MavlinkLink:
    """An ArduSub vehicle over MAVLink behind the :class:`trimd.core.link.Link` protocol.

    Attributes
    ----------
    description : the connection, for people.
    stats : :class:`LinkStats`.
    warnings : every warning so far (also carried in Health.detail).
    on_raw : optional ``callback(t_s, packet)`` for every good received packet.
    """

    def __init__(self, options: MavlinkOptions, profile: Profile) -> None:
        self.options = options
        self.profile = profile
        self.description = f"MAVLink {options.device}" + (
            f" (system {options.sysid})" if options.sysid is not None else "")
        self.stats = LinkStats()
        self.warnings: list[str] = []
        self.on_raw: Callable[[float, bytes], None] | None = None
        self._conn = _open(options)
        self._decoder = MavlinkDecoder.for_profile(profile, sysid=options.sysid,
                                                   depth_source=options.depth)
        self._stations = Stations(options.source)
        self._outbox = Outbox(self._conn.mav, t0=time.monotonic(), enabled=options.announce,
                              mav_type=mavlink2.MAV_TYPE_GCS if options.ids == "gcs"
                              else mavlink2.MAV_TYPE_ONBOARD_CONTROLLER)
        self._commander = Commander(self._conn.mav, profile, self._decoder, options, self._warn,
                                    self._stations)
        self._items: deque[_Item] = deque()
        self._commands: queue.SimpleQueue[tuple[Command, Future[None]]] = queue.SimpleQueue()
        self._seq: dict[tuple[int, int], int] = {}
        self._stop = threading.Event()
        self._stop_by = math.inf
        self._loop: asyncio.AbstractEventLoop | None = None
        self._wake = asyncio.Event()
        self._wake_pending = False
        self._error: str | None = None
        self._closed = False
        self._connected = False
        self._t_heartbeat = math.nan
        self._thread = threading.Thread(target=self._run, name="trimd-mavlink", daemon=True)
        self._thread.start()

    @property
    def params(self) -> VehicleParams:
        """The vehicle's parameters read so far (FRAME_CONFIG, SERVOn_FUNCTION, …)."""
        return self._decoder.params

    # ---------------------------------------------------------------- Link protocol
    async def samples(self) -> AsyncIterator[Sample]:
        """Samples as they arrive; LinkError when the transport fails, the end on close."""
        self._loop = asyncio.get_running_loop()
        self._wake_pending = False
        self._wake.set()
        taken = 0
        while True:
            await self._wake.wait()
            self._wake.clear()
            while self._items:
                t_s, raw, samples = self._items.popleft()
                if raw is not None and self.on_raw is not None:
                    self.on_raw(t_s, raw)
                for sample in samples:
                    yield sample
                taken += 1
                if taken % _BURST == 0:  # a backlog: let the loop run (signals, other tasks)
                    await asyncio.sleep(0)
            if not self._thread.is_alive() and not self._items:
                if self._closed:
                    return
                raise LinkError(self._error or "the MAVLink link stopped")

    async def send(self, command: Command) -> None:
        """Carry out ``command``; returns when the vehicle confirmed it (LinkError if not)."""
        if self._closed or not self._thread.is_alive():
            raise LinkError(self._error or "the MAVLink link is closed")
        check_command(command, self.profile)
        await self._submit(command)

    def announce(self, item: Announcement) -> None:
        """Queue a text or values for the network (:mod:`~trimd.drivers.mavlink.outbox`:
        its budget, its encoding); ignored once the link is closed."""
        if not self._closed:
            self._outbox.put(item)

    async def close(self) -> None:
        """Release (restoring the operator's mode), stop the I/O thread, close the port."""
        if self._closed:
            return
        self._closed = True
        if self._thread.is_alive():
            with contextlib.suppress(LinkError):
                await self._submit(Release())
            self._stop_by = time.monotonic() + _CLOSE_GRACE_S
            self._stop.set()
            await asyncio.to_thread(self._thread.join, _CLOSE_GRACE_S + 1.0)

    async def _submit(self, command: Command) -> None:
        done: Future[None] = Future()
        self._commands.put((command, done))
        try:
            await asyncio.wait_for(asyncio.wrap_future(done), _ANSWER_GUARD_S)
        except TimeoutError:
            raise LinkError(f"no answer from the MAVLink I/O thread to {command}") from None

    # ---------------------------------------------------------------- I/O thread
    def _run(self) -> None:
        now = time.monotonic()
        try:
            while not (self._stop.is_set() and (self._commander.idle or now > self._stop_by)):
                self._take_commands(now)
                next_due = min(self._commander.tick(now), self._outbox.tick(now))
                self._watchdog(now)
                self._conn.select(max(0.0, min(next_due - time.monotonic(), _POLL_S)))
                self._receive()
                now = time.monotonic()
        except Exception as exc:  # the transport failed: report it, end the stream
            self._error = f"mavlink:{self.options.device}: {exc}"
            log.error("%s", self._error)
            self._lost(time.monotonic(), self._error)
        finally:
            self._commander.on_lost()
            self._take_commands(now, refuse=self._error or "the MAVLink link is closed")
            with contextlib.suppress(Exception):
                if self._error is None:
                    self._outbox.flush(time.monotonic())
                self._conn.close()
            self._notify()

    def _take_commands(self, now: float, refuse: str | None = None) -> None:
        while True:
            try:
                command, done = self._commands.get_nowait()
            except queue.Empty:
                return
            if refuse is not None:
                done.set_exception(LinkError(refuse))
            else:
                self._commander.apply(command, now, done)

    def _receive(self) -> None:
        for _ in range(_BURST):
            msg = self._conn.recv_msg()
            if msg is None:
                return
            self._handle(msg, time.monotonic())

    def _handle(self, msg: MavMessage, now: float) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA":
            if "signature" in str(msg.reason):
                self.stats.refused += 1
            else:
                self.stats.bad_frames += 1
            return
        self.stats.messages += 1
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        last = self._seq.get(source)
        if last is not None:
            self.stats.gaps[source] += (msg.get_seq() - last - 1) & 0xFF
        self._seq[source] = msg.get_seq()
        self._decoder.bad_frames = self.stats.bad_frames
        samples = self._decoder.decode(msg, now)
        if source == self._decoder.vehicle:
            if kind == "HEARTBEAT":
                self._t_heartbeat = now
                if not self._connected:
                    self._connected = True
                    self._commander.on_vehicle(now)
            took = self._commander.on_message(msg, now)
        else:
            self._stations.heard(source, now)
            took = self._from_other(msg, kind, now)
        if took is not None:
            samples.append(PilotInput(now, took))
        if self.warnings:
            detail = "; ".join(self.warnings)
            samples = [dataclasses.replace(s, detail=detail) if isinstance(s, Health) else s
                       for s in samples]
        if samples or self.on_raw is not None:
            self._push((now, bytes(msg.get_msgbuf()), samples))

    def _from_other(self, msg: MavMessage, kind: str, now: float) -> str | None:
        """Another system's message: a ground station's heartbeat or stick input; words
        for a PilotInput when it takes the vehicle from trimd."""
        commander, vehicle = self._commander, self._decoder.vehicle
        if kind == "HEARTBEAT":
            new = self._stations.heartbeat(msg, now)
            if new is None:
                return None
            name = self._stations.describe(new)
            self._warn(f"{name} is connected: trimd sends no MANUAL_CONTROL beside it (that "
                       "station has the sticks and feeds ArduSub's pilot-input failsafe)")
            if commander.commanding and commander.target is None:  # open-loop input
                return commander.yield_control(now, f"{name} connected during open-loop input")
        elif kind == "MANUAL_CONTROL" and vehicle is not None and commander.commanding:
            text = self._stations.stick_input(msg, vehicle[0])
            if text is not None:
                return commander.yield_control(now, text)
        return None

    def _watchdog(self, now: float) -> None:
        for gone in self._stations.gone(now):
            self._warn(f"{self._stations.describe(gone)} silent for {STATION_TIMEOUT_S:g} s: "
                       "gone")
        if self._connected and now - self._t_heartbeat > self.options.timeout_s:
            vehicle = self._decoder.vehicle or (0, 0)
            self._lost(now, f"no heartbeat from the vehicle (system {vehicle[0]}, component "
                            f"{vehicle[1]}) for {self.options.timeout_s:g} s")

    def _lost(self, now: float, detail: str) -> None:
        self._connected = False
        self._commander.on_lost()
        d = self._decoder
        self._push((now, None, [Health(now, False, d.mode or "", bool(d.armed),
                                       self.stats.bad_frames, detail,
                                       mode_class=d.mode_class)]))

    def _warn(self, text: str) -> None:
        if text not in self.warnings:
            self.warnings.append(text)
            log.warning("%s", text)

    # ---------------------------------------------------------------- to the event loop
    def _push(self, item: _Item) -> None:
        if len(self._items) >= _MAX_ITEMS:
            self._items.popleft()
            self.stats.dropped += 1
        self._items.append(item)
        self._notify()

    def _notify(self) -> None:
        loop = self._loop
        if loop is None or self._wake_pending:
            return
        self._wake_pending = True
        with contextlib.suppress(RuntimeError):  # the loop has closed
            loop.call_soon_threadsafe(self._woken)

    def _woken(self) -> None:
        self._wake_pending = False
        self._wake.set()


def open_mavlink_link(rest: str, profile: Profile, stream_hz: float | None = None
                      ) -> MavlinkLink:
    """A :class:`MavlinkLink` for what follows ``mavlink:`` (``trimd.drivers.mavlink.url``);
    ``stream_hz``: the telemetry rate to ask for when the URL gives no ``rate``."""
    # heartbeats come at 1 Hz: never lost sooner than 3 s (the procedure releases on its
    # own after link_timeout_s without any telemetry)
    options = parse_mavlink_url(rest, default_timeout_s=max(
        3.0, profile.procedure.link_timeout_s), default_stream_hz=stream_hz)
    return MavlinkLink(options, profile)
