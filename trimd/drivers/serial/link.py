"""The serial driver: a vehicle speaking the trimd line protocol (``serial:<device>[,baud]``).

Opened with pyserial's ``serial_for_url``, so real ports (``/dev/ttyUSB0``), pseudo-
terminals and pyserial's URLs (``loop://``, ``socket://host:port``) all work. One reader
thread owns the port's input: it parses lines (:mod:`trimd.drivers.serial.protocol`; bad lines
are counted and dropped), converts them to samples and hands them to :meth:`samples`.
The same thread sends the version handshake until the vehicle answers and, every
``control_period_s``, the control sentence (the active hold or open-loop command again,
else a heartbeat), so a vehicle that stops hearing trimd releases by itself.

Time: every sample is stamped on the ``time.monotonic()`` base, advanced by the vehicle's
own clock (each sentence's ``t_ms``) rather than by the time of receipt: serial buffering
and chunked reads then cannot bunch samples together, and a simulator served at ``--rate
X`` keeps its own time, as the procedure's windows need. The first sentence (and any
jump of the vehicle clock back by more than 1 s, i.e. a reboot) anchors the vehicle clock
to ``time.monotonic()``; a jump forward (a time sync) counts as one ordinary step.

Link loss: no valid sentence for ``timeout_s`` (default 1 s) after the handshake yields a
disconnected :class:`Health` (the reader checks every 50 ms); a device error (a port
unplugged, a pseudo-terminal whose vehicle exited) yields one at once and ends the stream
with a :class:`LinkError` saying why. So does a vehicle answering the handshake with
another protocol version. Until the handshake is answered, each VHSTA (or, without one,
any telemetry once a second) gives a disconnected Health saying what is missing.

The pilot: when the vehicle reports (VHSTA) that control went from trimd's hold or
open-loop input back to the pilot while trimd still commands, or that the pilot still
flies :data:`NOT_TAKEN_AFTER` status sentences, and :data:`NOT_TAKEN_S` of wall clock,
after trimd's command, the link yields a
:class:`PilotInput`, on which the procedure releases and ends: no data from the pilot's
flying is taken for a hold.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections import deque
from collections.abc import AsyncIterator

import numpy as np
import serial

from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.samples import (
    Command,
    Health,
    HoldAttitude,
    ModeClass,
    OpenLoop,
    PilotInput,
    Release,
    Sample,
)
from trimd.drivers.limits import check_command
from trimd.drivers.serial.protocol import (
    MAX_OUTPUTS,
    VEHICLE,
    VERSION,
    Heartbeat,
    LineParser,
    Sentence,
    Version,
    encode_command,
    to_sample,
)

__all__ = ["CONTROL_PERIOD_S", "DEFAULT_BAUD", "NOT_TAKEN_AFTER", "NOT_TAKEN_S", "TIMEOUT_S",
           "SerialLink", "open_serial_link"]

DEFAULT_BAUD = 115_200
#: Vehicle silence that makes the link lost [s].
TIMEOUT_S = 1.0
#: Period of the control sentence (and of the handshake until answered) [s].
CONTROL_PERIOD_S = 0.5
#: Before the handshake, a vehicle's telemetry yields a disconnected Health (with the reason)
#: at most this often [s, wall clock], VHSTA or not.
WAITING_EVERY_S = 1.0
#: While trimd commands, this many VHSTA in a row saying control PILOT (1 Hz: the first
#: may have left before the vehicle had trimd's command) mean the vehicle did not take it,
#: once the last of them came this long [s, wall clock] after trimd took control: a
#: vehicle (or a simulator faster than real time) sending status faster than the command
#: reaches it is not taken for one that refused it.
NOT_TAKEN_AFTER, NOT_TAKEN_S = 3, 1.0
_READ_TIMEOUT_S = 0.05
_WRITE_TIMEOUT_S = 1.0
_QUEUE_MAX = 20_000
_REBOOT_MS = -1000
#: A forward step of the vehicle clock beyond this [s] and this many recent steps is a jump.
_JUMP_S = 5.0
_JUMP_FACTOR = 50.0


class _VehicleClock:
    """Vehicle ``t_ms`` (uint32, wrapping) → seconds on the ``time.monotonic()`` base.

    A step back of more than 1 s is a reboot: re-anchored to ``now``. A step forward of
    more than :data:`_JUMP_S` and :data:`_JUMP_FACTOR` times the recent steps between
    sentences is the vehicle's clock being set (a time sync), not time passing: it counts
    as one ordinary step, so a hold is not cut short by a jump it did not live through.
    """

    def __init__(self) -> None:
        self._ms: int | None = None
        self._t = 0.0
        self._steps: deque[float] = deque(maxlen=32)

    def stamp(self, t_ms: int, now: float) -> float:
        if self._ms is not None:
            step = ((t_ms - self._ms + 2**31) % 2**32 - 2**31) / 1000.0
            if step >= _REBOOT_MS / 1000.0:
                usual = float(np.median(self._steps)) if self._steps else 0.0
                if step > max(_JUMP_S, _JUMP_FACTOR * usual) and self._steps:
                    step = usual
                elif step > 0:
                    self._steps.append(step)
                self._ms, self._t = t_ms, self._t + step
                return self._t
        self._ms, self._t = t_ms, now
        self._steps.clear()
        return now


class SerialLink:
    """A vehicle on an open pyserial port, behind the :class:`trimd.core.link.Link` protocol.

    Parameters
    ----------
    port : an open pyserial port whose read timeout is short (≈ 50 ms).
    profile : the vehicle; its thrusters' ``channel`` select THR outputs (1…16).
    timeout_s : vehicle silence that makes the link lost [s].
    control_period_s : period of the control sentence [s].

    Attributes
    ----------
    parser : the line parser (``parser.counts``: lines by outcome).
    vehicle : the vehicle's answer to the handshake, None until it came.
    dropped : samples dropped because the consumer fell behind by ``_QUEUE_MAX``.
    unmapped : THR sentences that did not drive every thruster of the profile (dropped).
    """

    def __init__(self, port: serial.Serial, profile: Profile, *, description: str,
                 timeout_s: float = TIMEOUT_S,
                 control_period_s: float = CONTROL_PERIOD_S) -> None:
        self.channels = tuple(t.channel for t in profile.thrusters)
        if max(self.channels) > MAX_OUTPUTS:
            raise LinkError(f"profile {profile.name}: the serial protocol carries outputs "
                            f"1…{MAX_OUTPUTS}, the thrusters use {self.channels}")
        self.port = port
        self.profile = profile
        self.description = description
        self.timeout_s = timeout_s
        self.control_period_s = control_period_s
        self.parser = LineParser(VEHICLE)
        self.vehicle: Version | None = None
        self.dropped = 0
        self.unmapped = 0
        self._problem = ("the vehicle sends telemetry but has not answered trimd's version "
                         "sentence (TRVER) with VHVER")
        self._fatal = ""   # why the stream ended, for the LinkError that ends it
        self._flying = ""  # who flies, as the vehicle's last VHSTA said
        self._t_waiting = -WAITING_EVERY_S  # monotonic: when a not-connected Health went out
        self._pilot_stas = 0  # VHSTAs in a row saying PILOT while trimd commands
        self._pilot_said = False  # a PilotInput was yielded for this command
        self._t_taken = 0.0  # monotonic: when trimd took control afresh
        self._clock = _VehicleClock()
        self._pending: deque[Sample] = deque()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._wake: asyncio.Event | None = None
        self._active: Command | Heartbeat = Heartbeat()
        self._commanded = False
        self._connected = False
        self._finished = False
        self._closed = False
        self._last: Health | None = None
        self._last_rx = (0.0, 0.0)   # (monotonic, sample time) of the last valid sentence
        self._write_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"serial {description}",
                                        daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ Link protocol
    async def samples(self) -> AsyncIterator[Sample]:
        """Samples as the reader thread delivers them, until the device fails or closes."""
        self._wake = wake = asyncio.Event()
        self._loop = asyncio.get_running_loop()
        try:
            while True:
                while self._pending:
                    yield self._pending.popleft()
                if self._fatal and not self._closed:
                    raise LinkError(self._fatal)
                if self._finished or self._closed:
                    return
                wake.clear()
                if not self._pending and not self._finished:
                    await wake.wait()
        finally:
            if self._wake is wake:   # not a newer consumer's
                self._loop = self._wake = None

    async def send(self, command: Command) -> None:
        """Send ``command`` now; holds and open-loop inputs are repeated every control
        period until the next command. Release is always sent; other commands need the
        version handshake."""
        if self._closed:
            raise LinkError(f"{self.description} is closed")
        check_command(command, self.profile)
        if not isinstance(command, Release) and self.vehicle is None:
            raise LinkError(f"{self.description}: {self._problem}")
        try:
            line = encode_command(command)
        except ValueError as exc:
            raise LinkError(f"not sent: {exc}") from None
        if isinstance(command, HoldAttitude | OpenLoop):
            if isinstance(self._active, Heartbeat):   # trimd takes control afresh
                self._pilot_stas, self._pilot_said = 0, False
                self._t_taken = time.monotonic()
            self._active, self._commanded = command, True
        elif isinstance(command, Release):
            self._active = Heartbeat()
        self._write(line)

    async def close(self) -> None:
        """Release the vehicle if trimd commanded it, stop the reader, close the port."""
        if self._closed:
            return
        self._closed = True
        self._active = Heartbeat()
        if self._commanded:
            # if this fails, the vehicle releases by itself when trimd falls silent
            with contextlib.suppress(LinkError):
                self._write(encode_command(Release()))
        self._stop.set()
        self._thread.join(timeout=1.0)
        self.port.close()
        self._notify()

    # ------------------------------------------------------------------ reader thread
    def _run(self) -> None:
        next_control = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            try:
                if now >= next_control:
                    next_control = now + self.control_period_s
                    self._control()
                data = self.port.read(self.port.in_waiting or 1)
            except (serial.SerialException, OSError, LinkError) as exc:
                if not self._stop.is_set():
                    self._end(f"{self.description}: {exc}", time.monotonic())
                return
            now = time.monotonic()
            for sentence in self.parser.feed(data) if data else ():
                self._on_sentence(sentence, now)
            if self._finished:
                return
            if self._connected and now - self._last_rx[0] > self.timeout_s:
                self._lose(f"no data from the vehicle for {now - self._last_rx[0]:.1f} s", now)
            if self._pending:
                self._notify()

    def _control(self) -> None:
        if self.vehicle is None:
            self._write(encode_command(Version(VERSION, "trimd")))
        self._write(encode_command(self._active))

    def _on_sentence(self, s: Sentence, now: float) -> None:
        t_s = self._clock.stamp(int(s.values[0]), now) if s.kind != "VER" else self._last_rx[1]
        self._last_rx = (now, t_s)
        out = to_sample(s, t_s, self.channels)
        if isinstance(out, Version):
            if out.version == VERSION:
                self.vehicle, self._problem = out, ""
            elif not self._finished:
                self.vehicle = None
                self._problem = (f"the vehicle ({out.name}) speaks serial protocol version "
                                 f"{out.version}, trimd speaks {VERSION}")
                self._end(self._problem, now)
            return
        if isinstance(out, Health):
            self._connected = self.vehicle is not None
            out = Health(t_s, self._connected, out.mode, out.armed, self.parser.bad_lines,
                         out.detail if self._connected else self._problem,
                         self.vehicle.name if self.vehicle else "", out.mode_class)
            self._last = out
            self._emit(out)
            self._on_control(str(s.values[3]), out, now)   # STA: t_ms, mode, armed, control
            if not self._connected:
                self._t_waiting = now
            return
        if out is None:
            self.unmapped += 1
        else:
            self._emit(out)
        if self.vehicle is None and now - self._t_waiting >= WAITING_EVERY_S:
            # a vehicle that talks without a VHSTA: say why it is not connected all the same
            self._t_waiting = now
            self._emit(Health(t_s, False, "", False, self.parser.bad_lines, self._problem))

    def _on_control(self, control: str, health: Health, now: float) -> None:
        """While trimd commands, the pilot flies if the vehicle handed control back (HOLD/
        OPEN → PILOT) or never took trimd's command (PILOT in :data:`NOT_TAKEN_AFTER`
        status sentences in a row, the last :data:`NOT_TAKEN_S` or more after the command,
        ``now`` [s, monotonic] the sentence's receipt): say so with one PilotInput.
        trimd's own release sets ``_active`` first, so the PILOT after it is no takeover."""
        previous, self._flying = self._flying, control
        if (control != "PILOT" or self._pilot_said
                or not isinstance(self._active, HoldAttitude | OpenLoop)):
            self._pilot_stas = 0
            return
        self._pilot_stas += 1
        if previous in ("HOLD", "OPEN"):
            source = f"the vehicle reports control PILOT, mode {health.mode}"
        elif self._pilot_stas >= NOT_TAKEN_AFTER and now - self._t_taken >= NOT_TAKEN_S:
            source = (f"the vehicle did not take trimd's command: control PILOT in "
                      f"{self._pilot_stas} status sentences, mode {health.mode}")
        else:
            return
        self._pilot_said = True
        self._emit(PilotInput(health.t_s, source))

    def _end(self, reason: str, now: float) -> None:
        """The stream ends: a disconnected Health, then a LinkError saying ``reason``."""
        self._lose(reason, now)
        self._fatal, self._finished = reason, True
        self._notify()

    def _lose(self, detail: str, now: float) -> None:
        """The vehicle is gone: stop repeating a command (one must come again after a
        loss, as over MAVLink) and say so with a disconnected Health."""
        self._connected = False
        self._active = Heartbeat()
        last = self._last
        t_s = self._last_rx[1] + (now - self._last_rx[0])
        self._emit(Health(t_s, False, last.mode if last else "", bool(last and last.armed),
                          self.parser.bad_lines, detail, last.vehicle if last else "",
                          last.mode_class if last else ModeClass.UNKNOWN))

    def _emit(self, sample: Sample) -> None:
        if len(self._pending) >= _QUEUE_MAX:
            self._pending.popleft()
            self.dropped += 1
        self._pending.append(sample)

    def _notify(self) -> None:
        loop, wake = self._loop, self._wake
        if loop is not None and wake is not None:
            with contextlib.suppress(RuntimeError):   # the consumer's loop has closed
                loop.call_soon_threadsafe(wake.set)

    def _write(self, line: bytes) -> None:
        try:
            with self._write_lock:
                self.port.write(line)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"{self.description}: cannot write: {exc}") from None


def open_serial_link(rest: str, profile: Profile, *, timeout_s: float = TIMEOUT_S
                     ) -> SerialLink:
    """A :class:`SerialLink` for the ``<device>[,<baud>]`` part of a ``serial:`` URL.

    Raises
    ------
    LinkError
        For a missing device, a baud rate that is not a positive integer, or a port that
        cannot be opened.
    """
    device, baud = rest, DEFAULT_BAUD
    head, sep, tail = rest.rpartition(",")
    if sep:
        if not tail.isdigit() or int(tail) == 0:
            raise LinkError(f"serial:{rest}: the baud rate must be a positive integer, "
                            f"got '{tail}'")
        device, baud = head, int(tail)
    if not device:
        raise LinkError("serial: needs a device, e.g. serial:/dev/ttyUSB0,115200")
    try:
        port = serial.serial_for_url(device, baudrate=baud, timeout=_READ_TIMEOUT_S,
                                     write_timeout=_WRITE_TIMEOUT_S)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise LinkError(f"cannot open serial {device}: {exc}") from None
    return SerialLink(port, profile, description=f"serial {device} at {baud} baud",
                      timeout_s=timeout_s)
