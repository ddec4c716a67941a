"""Session recorder: a MAVLink 2 ``.tlog`` that pymavlink's mavlogdump and MAVExplorer open.

Each record is an 8-byte big-endian timestamp [µs since the Unix epoch] followed by one
MAVLink 2 packet. The first record (a STATUSTEXT "trimd session start") is session time
zero; a replay measures every sample's time from it.

* Samples are written as the standard messages that carry them, from system 1 /
  component 1 (the vehicle): ATTITUDE, SERVO_OUTPUT_RAW (the profile's channels),
  VFR_HUD (alt = −depth), SYS_STATUS (battery mV), HEARTBEAT (ArduSub mode, armed),
  ODOMETRY with child frame MAV_FRAME_BODY_FRD for a body velocity (DVL): vx, vy, vz =
  u, v, w; position and orientation unknown (NaN), as MAVLink allows; STATUSTEXT for the
  vehicle's own messages.
* Commands and the procedure's events come from system 255 / component 190 (trimd):
  SET_ATTITUDE_TARGET for a hold, STATUSTEXT for release, notices and warnings,
  NAMED_VALUE_FLOAT for the result.
* The vehicle profile rides along as gzip-compressed YAML in ENCAPSULATED_DATA packets,
  so a trimd recording replays without ``--profile``; a verify hold's recording carries
  its verify target (:mod:`trimd.app.verify`) the same way, as gzip-compressed JSON, so
  its replay is a verify hold too, and a deliberate calibration's level hold
  (:mod:`trimd.app.calibrate`) which hold it is and the weight hung, and a float check
  (:mod:`trimd.app.float_check`) its settings, so that its replay is a float check. Each
  block follows a STATUSTEXT that names it (:data:`PROFILE_BLOCK`, :data:`VERIFY_BLOCK`,
  :data:`CALIBRATION_HOLD_BLOCK`, :data:`FLOAT_BLOCK`); a reader that knows only the
  profile stops at the next one.

:meth:`TlogRecorder.sample` returns the sample *as the log stores it* (float32 angles,
integer PWM, millivolts): the live procedure sees exactly what a replay will see. The file
is flushed and synced at least once a second, so after ``kill -9`` at most a second is lost.
"""

from __future__ import annotations

import dataclasses
import gzip
import json
import math
import os
import struct
import time
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.calibration_json import posterior_to_dict
from trimd.core.events import Notice
from trimd.core.model import quaternion_from_euler
from trimd.core.profile import Profile
from trimd.core.samples import (
    Arm,
    Attitude,
    Battery,
    Command,
    Depth,
    Health,
    HoldAttitude,
    OpenLoop,
    PilotInput,
    Release,
    Sample,
    Thrusters,
    VehicleText,
    Velocity,
)
from trimd.drivers.mavlink.ardusub import mode_class, mode_name, mode_number
from trimd.drivers.mavlink.message import MavEncoder, MavMessage
from trimd.drivers.mavlink.statustext import text_chunks

__all__ = ["CALIBRATION_BLOCK", "CALIBRATION_HOLD_BLOCK", "FLOAT_BLOCK", "PILOT_TEXT",
           "PROFILE_BLOCK",
           "TRIMD_COMPONENT", "TRIMD_SYSTEM", "VERIFY_BLOCK", "TlogRecorder", "session_s",
           "session_us"]

TRIMD_SYSTEM, TRIMD_COMPONENT = 255, 190
VEHICLE_SYSTEM, VEHICLE_COMPONENT = 1, 1
SESSION_START = "trimd session start"
#: How the STATUSTEXT before each block of ENCAPSULATED_DATA begins (the thrust map's
#: calibration: the profile's ``thrust_map``, :mod:`trimd.core.calibration`).
PROFILE_BLOCK, VERIFY_BLOCK = "trimd profile ", "trimd verify target"
CALIBRATION_BLOCK = "trimd thrust map calibration"
#: ... and before the block of a deliberate calibration's level hold (which hold, the weight)
CALIBRATION_HOLD_BLOCK = "trimd calibration hold"
#: ... and before the block of a float check's settings (:mod:`trimd.app.float_check`)
FLOAT_BLOCK = "trimd float check"
#: A :class:`PilotInput` is recorded as the vehicle's STATUSTEXT (warning) with this
#: prefix before its source; :class:`trimd.logs.log.TlogLog` reads it back as one.
PILOT_TEXT = "pilot took over: "
#: Longest time [s, wall clock] a written record waits before it is synced to the disk.
FLUSH_EVERY_S = 1.0
_UNKNOWN_MODE = 255  # written for a mode name ArduSub does not have
_SEVERITY = {"warning": 4, "state": 6, "info": 6, "result": 6}


def _f32(x: float) -> float:
    return float(np.float32(x))


def session_us(t_s: float) -> int:
    """Session time ``t_s`` [s] as a record's offset from the session's start [µs]."""
    return round(t_s * 1e6)


def session_s(offset_us: int) -> float:
    """A record's offset from the session's start [µs] as the session time a replay
    reads [s] (:meth:`trimd.logs.tlog.TlogReader.samples`): the float nearest the stored
    µs, so a time the session rounded to the millisecond reads back bit for bit (a
    product with 1e-6 would not: 50000 · 1e-6 is 0.049999999999999996, not 0.05, and the
    live procedure and its replay would see times one ulp apart, enough to move a cut).

    Examples
    --------
    >>> 1234.55 - 1200.0, session_s(session_us(1234.55 - 1200.0))
    (34.549999999999955, 34.55)
    >>> session_s(session_us(0.05)), session_s(50_000) == round(0.049999999999999996, 3)
    (0.05, True)
    """
    return offset_us / 1e6


class TlogRecorder:
    """Record one session to ``path`` (parent directories are created); ``verify_target``:
    the session is a verify hold of that target (:mod:`trimd.app.verify`);
    ``calibration_hold``: a deliberate calibration's level hold (:mod:`trimd.app.calibrate`:
    which hold, the weight); ``float_check``: a float check with these settings
    (:mod:`trimd.app.float_check`). A profile
    with a calibrated thrust map has it recorded too, so that a replay estimates as the
    live session did."""

    def __init__(self, path: str | Path, profile: Profile, profile_yaml: str, *,
                 verify_target: dict[str, Any] | None = None,
                 calibration_hold: dict[str, Any] | None = None,
                 float_check: dict[str, Any] | None = None) -> None:
        self.path = str(path)
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        self._file = open(path, "wb")  # noqa: SIM115 - kept open for the session
        self._channels = [t.channel for t in profile.thrusters]
        if max(self._channels, default=0) > 16:
            raise ValueError("SERVO_OUTPUT_RAW carries channels 1..16 only")
        self._epoch_us = int(time.time()) * 1_000_000
        self._vehicle = mavlink2.MAVLink(None, srcSystem=VEHICLE_SYSTEM,
                                         srcComponent=VEHICLE_COMPONENT)
        self._trimd = mavlink2.MAVLink(None, srcSystem=TRIMD_SYSTEM, srcComponent=TRIMD_COMPONENT)
        self._last_flush = time.monotonic()
        self._text_id = 0
        self._write_text(0.0, SESSION_START, 6)
        self._write_block(f"{PROFILE_BLOCK}{profile.name}", profile_yaml, "YAML")
        if profile.thrust_map is not None:
            self._write_block(CALIBRATION_BLOCK,
                              json.dumps(posterior_to_dict(profile.thrust_map)), "JSON")
        if verify_target is not None:
            self._write_block(VERIFY_BLOCK, json.dumps(verify_target), "JSON")
        if calibration_hold is not None:
            self._write_block(CALIBRATION_HOLD_BLOCK, json.dumps(calibration_hold), "JSON")
        if float_check is not None:
            self._write_block(FLOAT_BLOCK, json.dumps(float_check), "JSON")

    # ---------------------------------------------------------------- writing
    def _write(self, t_s: float, mav: MavEncoder, msg: MavMessage) -> None:
        self.raw(t_s, bytes(msg.pack(mav)))
        mav.seq = (mav.seq + 1) % 256  # pack() does not advance it; send() would

    def raw(self, t_s: float, packet: bytes) -> None:
        """Record a packet (e.g. as received from a MAVLink link) at session time ``t_s``."""
        stamp = self._epoch_us + session_us(t_s)
        self._file.write(struct.pack(">Q", stamp) + packet)
        self.flush_due()

    def flush_due(self) -> None:
        """Flush if the last flush is a second old or more (called on every write, and
        by the session while the link is quiet)."""
        now = time.monotonic()
        if now - self._last_flush >= FLUSH_EVERY_S:
            self.flush()
            self._last_flush = now

    def _write_text(self, t_s: float, text: str, severity: int,
                    mav: MavEncoder | None = None) -> None:
        """STATUSTEXT from trimd (or from ``mav``, e.g. the vehicle), in chunks."""
        mav = mav or self._trimd
        chunks = text_chunks(text)
        self._text_id = self._text_id % 65535 + 1 if len(chunks) > 1 else 0
        for seq, chunk in enumerate(chunks):
            self._write(t_s, mav, mav.statustext_encode(severity, chunk, self._text_id, seq))

    def _write_block(self, header: str, text: str, kind: str) -> None:
        """``text`` gzip-compressed in ENCAPSULATED_DATA packets after a STATUSTEXT
        ``header: N bytes gzip KIND``, all at session time 0."""
        data = gzip.compress(text.encode("utf-8"), mtime=0)
        self._write_text(0.0, f"{header}: {len(data)} bytes gzip {kind}", 6)
        for seq, start in enumerate(range(0, len(data), 253)):
            chunk = data[start:start + 253]
            self._write(0.0, self._trimd, self._trimd.encapsulated_data_encode(
                seq, chunk + bytes(253 - len(chunk))))

    def flush(self) -> None:
        """Push everything written so far to the disk."""
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        if not self._file.closed:
            self.flush()
            self._file.close()

    # ---------------------------------------------------------------- Recorder protocol
    def sample(self, s: Sample) -> Sample:
        """Write ``s``; return it as the log stores it (what a replay will read), its time
        included: to the microsecond, as :func:`session_s` reads it back."""
        s = dataclasses.replace(s, t_s=session_s(session_us(s.t_s)))
        ms = round(s.t_s * 1000) & 0xFFFFFFFF
        v = self._vehicle
        if isinstance(s, Attitude):
            self._write(s.t_s, v, v.attitude_encode(ms, s.phi, s.theta, s.psi, s.p, s.q, s.r))
            return Attitude(s.t_s, *(_f32(x) for x in (s.phi, s.theta, s.psi, s.p, s.q, s.r)))
        if isinstance(s, Thrusters):
            pwm = [min(max(round(p), 0), 65535) for p in s.pwm_us]
            servos = [0] * 16
            for ch, p in zip(self._channels, pwm, strict=True):
                servos[ch - 1] = p
            # time_usec is a uint32 [µs]: it wraps after 71.6 min, as the autopilot's does
            # (a replay times samples by the records' stamps, not by it)
            usec = int(s.t_s * 1e6) & 0xFFFFFFFF
            self._write(s.t_s, v, v.servo_output_raw_encode(usec, 0, *servos))
            return Thrusters(s.t_s, tuple(float(p) for p in pwm))
        if isinstance(s, Depth):
            self._write(s.t_s, v, v.vfr_hud_encode(0, 0, 0, 0, -s.depth_m, 0))
            return Depth(s.t_s, -_f32(-s.depth_m))
        if isinstance(s, Battery):
            mv = min(max(round(s.voltage_V * 1000), 0), 65535)
            self._write(s.t_s, v, v.sys_status_encode(0, 0, 0, 0, mv, -1, -1, 0, 0, 0, 0, 0, 0))
            return Battery(s.t_s, mv / 1000.0)
        if isinstance(s, Velocity):
            nan = math.nan
            self._write(s.t_s, v, v.odometry_encode(
                int(s.t_s * 1e6), mavlink2.MAV_FRAME_LOCAL_FRD, mavlink2.MAV_FRAME_BODY_FRD,
                nan, nan, nan, [nan] * 4, s.u, s.v, s.w, nan, nan, nan, [nan] * 21,
                [nan] * 21, 0, 0, 0))
            return Velocity(s.t_s, _f32(s.u), _f32(s.v), _f32(s.w))
        if isinstance(s, Health):
            if not s.connected:
                self._write_text(s.t_s, f"link lost: {s.detail}", 3)
                return s
            base = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
                mavlink2.MAV_MODE_FLAG_SAFETY_ARMED if s.armed else 0)
            try:
                number = mode_number(s.mode)
            except ValueError:
                number = _UNKNOWN_MODE
            self._write(s.t_s, v, v.heartbeat_encode(
                mavlink2.MAV_TYPE_SUBMARINE, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                number, mavlink2.MAV_STATE_ACTIVE))
            return Health(s.t_s, True, mode_name(number), s.armed, vehicle=s.vehicle,
                          mode_class=mode_class(number))
        if isinstance(s, VehicleText):
            severity = min(max(s.severity, 0), 7)
            self._write_text(s.t_s, s.text, severity, v)
            return VehicleText(s.t_s, severity, s.text)
        if isinstance(s, PilotInput):
            self._write_text(s.t_s, PILOT_TEXT + s.source, 4, v)
        return s

    def command(self, t_s: float, command: Command) -> None:
        g = self._trimd
        if isinstance(command, HoldAttitude):
            q = quaternion_from_euler(command.phi, command.theta, command.psi)
            self._write(t_s, g, g.set_attitude_target_encode(
                int(t_s * 1000) & 0xFFFFFFFF, VEHICLE_SYSTEM, VEHICLE_COMPONENT, 0b1000111, q,
                0, 0, 0, 0.5))
        elif isinstance(command, Release):
            self._write_text(t_s, "trimd: release control", 5)
        elif isinstance(command, OpenLoop):
            x, y, heave, _, _, r = (float(np.clip(a, -1, 1)) for a in command.axes)
            # ArduSub's throttle: 0..1000, 500 neutral, above 500 up; heave is positive down
            self._write(t_s, g, g.manual_control_encode(
                VEHICLE_SYSTEM, int(x * 1000), int(y * 1000), int(500 - 500 * heave),
                int(r * 1000), 0))
        elif isinstance(command, Arm):
            self._write(t_s, g, g.command_long_encode(
                VEHICLE_SYSTEM, VEHICLE_COMPONENT, mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                1.0 if command.armed else 0.0, 0, 0, 0, 0, 0, 0))

    def notice(self, notice: Notice[object, object]) -> None:
        self._write_text(notice.t_s, notice.text, _SEVERITY.get(notice.kind, 6))
        if notice.result is not None:
            estimate = notice.result.estimate
            g = self._trimd
            ms = int(notice.t_s * 1000) & 0xFFFFFFFF
            for name, value in (("m_ext_kg", estimate.m_ext_kg),
                                ("cg_x_m", estimate.r_g_m[0]), ("cg_y_m", estimate.r_g_m[1]),
                                ("cg_z_m", estimate.r_g_m[2])):
                self._write(notice.t_s, g, g.named_value_float_encode(
                    ms, name.encode(), float(value)))
