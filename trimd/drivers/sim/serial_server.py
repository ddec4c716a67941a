"""The simulated vehicle served over a pseudo-terminal in the trimd serial line protocol.

``trimd sim --serve serial:pty`` opens a pseudo-terminal (``os.openpty``, raw mode: no
echo, no CR/LF translation), prints its path (``/dev/pts/N``) and behaves like a vehicle
of ``docs/serial-protocol.md``:

* telemetry at the simulator's sample rates in simulated time (``attitude_hz`` …
  ``health_hz`` of :class:`~trimd.drivers.sim.config.SimConfig`; VEL only with ``dvl``), each
  sentence stamped with the vehicle clock ``t_ms`` (simulated milliseconds); VHVER at
  boot and in answer to every TRVER;
* TRHLD: depth and attitude hold (ALT_HOLD) at that attitude; TROPN: MANUAL with those
  axis inputs; TRARM: arm/disarm; TRREL, or a TRHBT while a trimd command is active, or
  no valid trimd sentence for :data:`COMMAND_TIMEOUT_S` of *wall-clock* time: release,
  back to the mode the vehicle had before trimd took control (level, same heading and
  depth; MANUAL with neutral inputs), saying so in a VHTXT after a silence. The silence
  timeout is a property of the link, so it runs on the wall clock even at ``--rate X``;
* the pilot can take the vehicle back at any time (:meth:`SerialServer.pilot_takes_over`,
  e.g. a mode switch on the pilot's console): control PILOT in a VHSTA sent at once, and
  no trimd hold or open-loop input is taken until trimd has released (TRREL or TRHBT),
  so a repeated hold sentence cannot take the vehicle back from the pilot.

Bad lines from trimd are counted (:attr:`SerialServer.parser`) and dropped. Output the
other end does not read is dropped beyond :data:`MAX_BACKLOG_BYTES` (counted).
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import threading
import time
import tty
from collections import Counter

from trimd.core.errors import LinkError
from trimd.core.samples import Arm, Command, HoldAttitude, OpenLoop, Release, VehicleText
from trimd.drivers.serial.protocol import (
    MAX_OUTPUTS,
    TRIMD,
    VEHICLE,
    VERSION,
    Heartbeat,
    LineParser,
    Version,
    encode,
    encode_sample,
    to_command,
)
from trimd.drivers.sim.controller import MODES
from trimd.drivers.sim.pacing import run_paced
from trimd.drivers.sim.vehicle import SimVehicle

__all__ = ["COMMAND_TIMEOUT_S", "MAX_BACKLOG_BYTES", "SerialServer"]

#: Without a valid trimd sentence for this long [s, wall clock] the vehicle releases.
COMMAND_TIMEOUT_S = 1.5
MAX_BACKLOG_BYTES = 65_536
_NEUTRAL = (0.0,) * 6


class SerialServer:
    """Serve ``vehicle`` on a new pseudo-terminal (:attr:`path`).

    Parameters
    ----------
    vehicle : the simulated vehicle.
    rate : simulated seconds per wall second in :meth:`run`.

    Attributes
    ----------
    path : the pseudo-terminal's device path, for ``serial:<path>``.
    parser : the parser of trimd's lines (``parser.counts``).
    control : PILOT, HOLD or OPEN (who is in control, as STA reports it).
    pilot_latched : the pilot took over; trimd's holds are ignored until it releases.
    heard : trimd's sentences handled, by kind (``HLD``, ``REL``, …).
    dropped_bytes : output dropped because nobody read it.
    """

    def __init__(self, vehicle: SimVehicle, *, rate: float = 1.0) -> None:
        channels = [t.channel for t in vehicle.profile.thrusters]
        if max(channels) > MAX_OUTPUTS:
            raise LinkError(f"the serial protocol carries outputs 1…{MAX_OUTPUTS}; "
                            f"{vehicle.profile.name} uses {channels}")
        self.vehicle = vehicle
        self.rate = rate
        self.channels = channels
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self._slave)
        self.parser = LineParser(TRIMD)
        self.control = "PILOT"
        self.pilot_latched = False
        self.heard: Counter[str] = Counter()
        self.dropped_bytes = 0
        self._takeover = ""   # a mode the pilot switched to, for the serving thread
        self._pilot_mode = vehicle.mode
        self._heard = math.nan
        self._backlog = b""
        c, dt = vehicle.config, vehicle.dt_s
        rates = {"attitude": c.attitude_hz, "thrusters": c.thrusters_hz, "depth": c.depth_hz,
                 "velocity": c.velocity_hz if c.dvl else 0.0, "battery": c.battery_hz,
                 "health": c.health_hz}
        self._every = [(kind, max(1, round(1.0 / (hz * dt)))) for kind, hz in rates.items()
                       if hz > 0]
        self._name = re.sub(r"[^A-Za-z0-9_.\-]", "_", vehicle.profile.name)[:32] or "sim"
        self._send(self._version())

    # ------------------------------------------------------------------ running
    def run(self, stop: threading.Event | None = None, duration_s: float = math.inf) -> None:
        """Serve until ``stop`` is set or ``duration_s`` of simulated time has passed, then
        close the pseudo-terminal (the other end sees the device go away)."""
        try:
            run_paced(self.vehicle, self.advance_to, self.master, rate=self.rate, stop=stop,
                      duration_s=duration_s)
        finally:
            self.close()

    def close(self) -> None:
        """Close both ends of the pseudo-terminal (idempotent)."""
        for fd in (self.master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        self.master = self._slave = -1

    def advance_to(self, t_s: float) -> None:
        """Step the vehicle to simulated time ``t_s`` [s], handling trimd's lines and
        sending each sentence when it is due."""
        v = self.vehicle
        while True:
            self.poll()
            if v.t_s + 0.5 * v.dt_s >= t_s:
                break
            v.step()
            self._send(b"".join(self._sentence(kind) for kind, n in self._every
                                if v.steps % n == 0))

    def poll(self) -> None:
        """Handle every line waiting from trimd; release after the silence timeout."""
        while True:
            try:
                data = os.read(self.master, 4096)
            except (BlockingIOError, OSError):
                break
            if not data:
                break
            for sentence in self.parser.feed(data):
                self._heard = time.monotonic()
                self.heard[sentence.kind] += 1
                self.handle(to_command(sentence))
        if self._takeover:
            self._pilot_takes_over(self._takeover)
            self._takeover = ""
        if self.control != "PILOT" and time.monotonic() - self._heard > COMMAND_TIMEOUT_S:
            self._release()
            self._say(4, f"trimd silent for {COMMAND_TIMEOUT_S:g} s: control back to the pilot")

    # ------------------------------------------------------------------ the pilot
    def pilot_takes_over(self, mode: str = "MANUAL") -> None:
        """The pilot switches the vehicle to ``mode`` (one of the simulator's
        :data:`~trimd.drivers.sim.controller.MODES`) and flies it; from any thread: the serving
        thread acts on it at its next poll."""
        if mode not in MODES:
            raise ValueError(f"the simulated vehicle flies {', '.join(MODES)}, not {mode}")
        self._takeover = mode

    def _pilot_takes_over(self, mode: str) -> None:
        v = self.vehicle
        self.pilot_latched = self.control != "PILOT"
        self.control = "PILOT"
        v.set_mode(mode)
        if mode == "MANUAL":
            v.open_loop(_NEUTRAL)
        else:
            v.level()
        self._send(self._sentence("health"))
        self._say(4, f"the pilot took control ({mode})")

    # ------------------------------------------------------------------ commands
    def handle(self, command: Command | Heartbeat | Version) -> None:
        """Act on one command from trimd (module docstring)."""
        v = self.vehicle
        if isinstance(command, Release | Heartbeat):
            self.pilot_latched = False   # trimd has let go
        if isinstance(command, Version):
            self._send(self._version())
        elif isinstance(command, Arm):
            v.arm(command.armed)
        elif isinstance(command, HoldAttitude | OpenLoop) and self.pilot_latched:
            return   # the pilot flies until trimd releases
        elif isinstance(command, HoldAttitude):
            self._take("HOLD")
            if v.mode != "ALT_HOLD":
                v.set_mode("ALT_HOLD")
            v.hold_attitude(command.phi, command.theta, command.psi)
        elif isinstance(command, OpenLoop):
            self._take("OPEN")
            v.open_loop(command.axes)
        elif isinstance(command, Release | Heartbeat) and self.control != "PILOT":
            self._release()

    def _take(self, control: str) -> None:
        if self.control == "PILOT":
            self._pilot_mode = self.vehicle.mode
        self.control = control

    def _release(self) -> None:
        v = self.vehicle
        self.control = "PILOT"
        if self._pilot_mode == "MANUAL":
            v.open_loop(_NEUTRAL)
        else:
            v.set_mode(self._pilot_mode)
            v.level()

    # ------------------------------------------------------------------ output
    def _version(self) -> bytes:
        return encode(VEHICLE, "VER", [str(VERSION), self._name])

    def _say(self, severity: int, text: str) -> None:
        """A VHTXT message for people (MAV_SEVERITY ``severity``)."""
        t = self.vehicle.t_s
        self._send(encode_sample(VehicleText(t, severity, text), round(t * 1000)))

    def _sentence(self, kind: str) -> bytes:
        sample = self.vehicle.sample(kind)
        return encode_sample(sample, round(sample.t_s * 1000), max(self.channels),
                             self.channels, self.control)

    def _send(self, data: bytes) -> None:
        if self.master < 0:
            return
        data = self._backlog + data
        try:
            written = os.write(self.master, data) if data else 0
        except (BlockingIOError, OSError):
            written = 0
        self._backlog = data[written:]
        if len(self._backlog) > MAX_BACKLOG_BYTES:
            self.dropped_bytes += len(self._backlog)
            self._backlog = b""
