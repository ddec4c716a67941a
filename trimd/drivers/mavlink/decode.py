"""Pure conversion of pymavlink messages into typed samples (SI units, FRD/NED).

No I/O and no clock: the caller passes each message with its time ``t_s`` [s]; the live
MAVLink driver and the ``.tlog`` reader share this module, and the DataFlash reader
shares its range checks (``checked_*``).

=====================  =========================================================
message                sample
=====================  =========================================================
HEARTBEAT              :class:`Health` (ArduSub mode name, armed = base_mode bit 128,
                       vehicle = sysid, autopilot and type) from the vehicle's
                       autopilot component only
STATUSTEXT             :class:`VehicleText` (severity, text; MAVLink 2 chunks joined)
                       from any component of the vehicle's system; those sent before
                       its first HEARTBEAT (the boot banner) follow that heartbeat
ATTITUDE               :class:`Attitude` (rad, rad/s; already NED→FRD)
SERVO_OUTPUT_RAW       :class:`Thrusters` (µs) in the profile's thruster order
VFR_HUD                :class:`Depth` = −alt [m]            (``depth_source="vfr_hud"``)
GLOBAL_POSITION_INT    :class:`Depth` = −relative_alt/1000 [m] (``"global_position"``)
SCALED_PRESSURE2       :class:`Depth` = (p − p_surface)/(ρ·g)  (``"pressure"``, Bar30)
ODOMETRY (body FRD)    :class:`Velocity` = vx, vy, vz [m/s] when child_frame_id is
                       MAV_FRAME_BODY_FRD (a DVL; trimd's recorder writes it)
SYS_STATUS             :class:`Battery` = voltage_battery/1000 [V]
BATTERY_STATUS (id 0)  :class:`Battery` = Σ valid cell entries/1000 [V]
PARAM_VALUE            :class:`VehicleParams` (FRAME_CONFIG, SERVOn_FUNCTION, MOT_n_DIRECTION,
                       BARO2_GND_PRESS)
=====================  =========================================================

Only one depth source yields samples, so depth never jumps between sensors with different
zero points. ``p_surface`` for the pressure source is, in order: the constructor argument,
else the vehicle's own ground calibration of that sensor (parameter BARO2_GND_PRESS [Pa];
SCALED_PRESSURE2 is the second barometer, the Bar30 on a BlueROV2). Until one is known a
pressure reading yields nothing and is counted in ``rejected``.

Thruster channels: a profile thruster's ``channel`` is the ArduSub motor number, which is
also its default output. When the vehicle's SERVOn_FUNCTION parameters are known, motor k
(function 33..40 for motors 1..8, 82..85 for 9..12) is read from the output that carries
it; otherwise from output ``channel``.

Values outside :data:`LIMITS` (or NaN/inf) are never yielded: the whole message is counted
in ``rejected[msg_type]``. Messages from other systems or components are ignored (counted
in ``ignored``); none is used before the vehicle's first autopilot HEARTBEAT, except
parameters, which are kept per sender and adopted when the vehicle is known.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Literal

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.profile import Profile
from trimd.core.samples import (
    Attitude,
    Battery,
    Depth,
    Health,
    ModeClass,
    Sample,
    Thrusters,
    VehicleText,
    Velocity,
)
from trimd.drivers.mavlink.ardusub import mode_class, mode_name
from trimd.drivers.mavlink.message import MavMessage

__all__ = ["LIMITS", "DepthSource", "MavlinkDecoder", "VehicleParams", "checked_attitude",
           "checked_battery", "checked_depth", "checked_thrusters", "motor_function"]

DepthSource = Literal["vfr_hud", "global_position", "pressure"]

#: Plausible ranges (inclusive): anything outside is a corrupt or failed reading.
#: Angles get 1e-6 rad of slack for float32 rounding of ±π.
LIMITS: dict[str, tuple[float, float]] = {
    "roll_rad": (-math.pi - 1e-6, math.pi + 1e-6),
    "pitch_rad": (-math.pi / 2 - 1e-6, math.pi / 2 + 1e-6),
    "yaw_rad": (-2 * math.pi - 1e-6, 2 * math.pi + 1e-6),
    "rate_rad_s": (-35.0, 35.0),  # ≈ ±2000 °/s, a gyro's full scale
    "pwm_us": (800.0, 2200.0),
    "depth_m": (-10.0, 11_000.0),
    "voltage_V": (1.0, 100.0),
    "pressure_Pa": (1.0, 1.2e8),
    "speed_m_s": (-20.0, 20.0),
}

_AUTOPILOT_INVALID = 8  # MAV_AUTOPILOT_INVALID: GCS, cameras, companions
_TYPE_GCS = 6
_ARMED = 128  # MAV_MODE_FLAG_SAFETY_ARMED
_UINT16_MAX = 65535
_FRAME_BODY_FRD = 12  # MAV_FRAME_BODY_FRD
_TEXT_CHUNK = 50  # STATUSTEXT text bytes: a shorter chunk ends a multi-chunk text
_TEXTS_PENDING = 8  # multi-chunk texts being joined at once (older ones are dropped)
_SEVERITY_MAX = 7  # MAV_SEVERITY_DEBUG
_TEXTS_EARLY = 32  # texts kept per system before the vehicle is known (the latest)
_AUTOPILOTS = {3: "ArduPilot", 12: "PX4"}


def vehicle_name(sysid: int, autopilot: int, mav_type: int) -> str:
    """E.g. ``"sysid 1 ArduPilot submarine"`` from a HEARTBEAT's sender and fields."""
    enums = mavlink2.enums
    kind = enums["MAV_TYPE"].get(mav_type)
    pilot = enums["MAV_AUTOPILOT"].get(autopilot)
    kind_name = kind.name.removeprefix("MAV_TYPE_").lower().replace("_", " ") if kind else (
        f"type {mav_type}")
    pilot_name = _AUTOPILOTS.get(autopilot) or (
        pilot.name.removeprefix("MAV_AUTOPILOT_") if pilot else f"autopilot {autopilot}")
    return f"sysid {sysid} {pilot_name} {kind_name}"


class _Skip:
    """A message that carries nothing for this decoder (not a rejection)."""


_SKIP = _Skip()


def _ok(value: float, limit: str) -> bool:
    lo, hi = LIMITS[limit]
    return lo <= value <= hi  # False for NaN


def checked_attitude(t_s: float, phi: float, theta: float, psi: float,
                     p: float, q: float, r: float) -> Attitude | None:
    """An :class:`Attitude` (rad, rad/s) or None when a value is out of range or NaN."""
    if (_ok(phi, "roll_rad") and _ok(theta, "pitch_rad") and _ok(psi, "yaw_rad")
            and _ok(p, "rate_rad_s") and _ok(q, "rate_rad_s") and _ok(r, "rate_rad_s")):
        return Attitude(t_s, phi, theta, psi, p, q, r)
    return None


def checked_thrusters(t_s: float, pwm_us: Iterable[float]) -> Thrusters | None:
    """A :class:`Thrusters` sample (µs) or None when an output is out of range."""
    values = tuple(float(v) for v in pwm_us)
    return Thrusters(t_s, values) if all(_ok(v, "pwm_us") for v in values) else None


def checked_depth(t_s: float, depth_m: float) -> Depth | None:
    """A :class:`Depth` [m, positive down] or None when out of range."""
    return Depth(t_s, depth_m) if _ok(depth_m, "depth_m") else None


def checked_battery(t_s: float, voltage_V: float) -> Battery | None:
    """A :class:`Battery` [V] or None when out of range."""
    return Battery(t_s, voltage_V) if _ok(voltage_V, "voltage_V") else None


def motor_function(motor: int) -> int:
    """ArduPilot SERVOn_FUNCTION value of motor ``motor`` (1..12).

    Examples
    --------
    >>> motor_function(1), motor_function(8), motor_function(9)
    (33, 40, 82)
    """
    if 1 <= motor <= 8:
        return 32 + motor
    if 9 <= motor <= 12:
        return 73 + motor
    raise ValueError(f"ArduPilot has motors 1..12, not {motor}")


@dataclass
class VehicleParams:
    """Vehicle parameters that matter to trimd, as read from PARAM_VALUE or PARM."""

    frame_config: int | None = None
    servo_function: dict[int, int] = field(default_factory=dict)  # output n → function
    motor_direction: dict[int, int] = field(default_factory=dict)  # motor k → ±1
    surface_pressure_Pa: float | None = None  # BARO2_GND_PRESS

    def update(self, name: str, value: float) -> bool:
        """Take one parameter; True when it was one of those above."""
        if not math.isfinite(value):
            return False
        if name == "FRAME_CONFIG":
            self.frame_config = int(value)
        elif name == "BARO2_GND_PRESS":
            self.surface_pressure_Pa = value if _ok(value, "pressure_Pa") else None
        elif name.startswith("SERVO") and name.endswith("_FUNCTION") and name[5:-9].isdigit():
            self.servo_function[int(name[5:-9])] = int(value)
        elif (name.startswith("MOT_") and name.endswith("_DIRECTION")
              and name[4:-10].isdigit()):
            self.motor_direction[int(name[4:-10])] = 1 if value >= 0 else -1
        else:
            return False
        return True

    def motors(self) -> tuple[int, ...]:
        """Motor numbers some SERVOn_FUNCTION carries; motors 1..8 when none is known."""
        present = set(self.servo_function.values())
        found = tuple(k for k in range(1, 13) if motor_function(k) in present)
        return found or tuple(range(1, 9))

    def output_of(self, channel: int) -> int:
        """Output (servo) number that drives motor ``channel``; ``channel`` when unknown."""
        if 1 <= channel <= 12:
            function = motor_function(channel)
            for output, f in sorted(self.servo_function.items()):
                if f == function:
                    return output
        return channel

    def disagreements(self, profile: Profile) -> list[str]:
        """Where these parameters contradict the profile (empty when they agree)."""
        out = []
        if profile.frame_config is not None and self.frame_config not in (
                None, profile.frame_config):
            out.append(f"FRAME_CONFIG is {self.frame_config}, the profile "
                       f"'{profile.name}' is written for {profile.frame_config}")
        for t in profile.thrusters:
            if (self.servo_function and t.channel <= 12
                    and motor_function(t.channel) not in self.servo_function.values()):
                out.append(f"thruster {t.name}: no SERVOn_FUNCTION is motor {t.channel} "
                           f"({motor_function(t.channel)}); reading output {t.channel}")
            direction = self.motor_direction.get(t.channel)
            if direction is not None and (direction < 0) != t.reversed:
                out.append(f"thruster {t.name}: MOT_{t.channel}_DIRECTION = {direction} but "
                           f"the profile says reversed = {str(t.reversed).lower()}")
        return out


class MavlinkDecoder:
    """Turn pymavlink messages into samples for one vehicle.

    Parameters
    ----------
    channels : the profile's thruster channels (ArduSub motor numbers), in order; None:
        the vehicle's motors (:meth:`VehicleParams.motors`), for a log without a profile.
    rho_kg_m3, g_m_s2 : water density and gravity for the pressure depth source.
    sysid : the vehicle's system id; None = the first autopilot that is not a GCS.
    depth_source : which message yields :class:`Depth` (see the module docstring).
    surface_pressure_Pa : p_surface [Pa] for the pressure source (None: BARO2_GND_PRESS).
    """

    def __init__(self, channels: Sequence[int] | None = None, *, rho_kg_m3: float = 1025.0,
                 g_m_s2: float = 9.80665, sysid: int | None = None,
                 depth_source: DepthSource = "vfr_hud",
                 surface_pressure_Pa: float | None = None) -> None:
        if channels is not None and any(not 1 <= c <= 32 for c in channels):
            raise ValueError(f"SERVO_OUTPUT_RAW carries outputs 1..32, not {list(channels)}")
        self.channels = None if channels is None else tuple(channels)
        self.rho_g = rho_kg_m3 * g_m_s2
        self.sysid = sysid
        self.depth_source: DepthSource = depth_source
        self.surface_pressure_Pa = surface_pressure_Pa
        self.params = VehicleParams()
        self._params_by_source: dict[tuple[int, int], VehicleParams] = {}
        self.vehicle: tuple[int, int] | None = None
        self.mode: str | None = None
        self.mode_class = ModeClass.UNKNOWN
        self.armed: bool | None = None
        self.bad_frames = 0  # kept up to date by the transport; Health samples carry it
        self.rejected: Counter[str] = Counter()
        self.ignored = 0
        self._outputs: dict[int, int] = {}
        self._vehicle_name = ""
        self._texts: dict[tuple[int, int], list[bytes]] = {}  # (sysid, text id) → chunks
        self._early_texts: dict[int, list[VehicleText]] = {}
        depth_type = {"vfr_hud": "VFR_HUD", "global_position": "GLOBAL_POSITION_INT",
                      "pressure": "SCALED_PRESSURE2"}[depth_source]
        self._handlers = {
            "ATTITUDE": self._attitude, "SERVO_OUTPUT_RAW": self._servo,
            depth_type: getattr(self, f"_{depth_source}"), "SYS_STATUS": self._sys_status,
            "BATTERY_STATUS": self._battery_status, "ODOMETRY": self._odometry,
        }

    @classmethod
    def for_profile(cls, profile: Profile, *, sysid: int | None = None,
                    depth_source: DepthSource = "vfr_hud") -> MavlinkDecoder:
        """A decoder for ``profile``'s thruster channels, water density and gravity."""
        return cls([t.channel for t in profile.thrusters], sysid=sysid,
                   rho_kg_m3=profile.water_density_kg_m3, g_m_s2=profile.gravity_m_s2,
                   depth_source=depth_source)

    def decode(self, msg: MavMessage, t_s: float) -> list[Sample]:
        """Samples carried by one pymavlink message received at ``t_s`` [s] (often none)."""
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            return self._heartbeat(msg, t_s)
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "PARAM_VALUE":  # kept per sender until the vehicle is known
            params = self._params_by_source.setdefault(source, VehicleParams())
            params.update(str(msg.param_id), float(msg.param_value))
            return []
        if kind == "STATUSTEXT":
            if self.vehicle is None:  # kept per system until the vehicle is known
                early = self._early_texts.setdefault(source[0], [])
                early += self._statustext(msg, t_s)
                del early[:-_TEXTS_EARLY]
                return []
            if source[0] != self.vehicle[0]:
                self.ignored += 1
                return []
            return list(self._statustext(msg, t_s))
        handler = self._handlers.get(kind)
        if handler is None:
            return []
        if source != self.vehicle:
            self.ignored += 1
            return []
        sample: Sample | _Skip | None = handler(msg, t_s)
        if sample is None:
            self.rejected[kind] += 1
            return []
        return [] if isinstance(sample, _Skip) else [sample]

    # ------------------------------------------------------------------ handlers
    def _heartbeat(self, msg: MavMessage, t_s: float) -> list[Sample]:
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.vehicle is None:
            if (msg.autopilot == _AUTOPILOT_INVALID or msg.type == _TYPE_GCS
                    or self.sysid not in (None, source[0])):
                self.ignored += 1
                return []
            self.vehicle = source
            self.params = self._params_by_source.setdefault(source, VehicleParams())
            self._vehicle_name = vehicle_name(source[0], int(msg.autopilot), int(msg.type))
        elif source != self.vehicle:
            self.ignored += 1
            return []
        self.mode = mode_name(int(msg.custom_mode))
        self.mode_class = mode_class(int(msg.custom_mode))
        self.armed = bool(msg.base_mode & _ARMED)
        early = self._early_texts.pop(source[0], [])
        self._early_texts.clear()
        return [Health(t_s, True, self.mode, self.armed, self.bad_frames,
                       vehicle=self._vehicle_name, mode_class=self.mode_class), *early]

    def _statustext(self, msg: MavMessage, t_s: float) -> list[VehicleText]:
        # pymavlink decodes the text as ASCII; the raw bytes keep UTF-8 (e.g. "°") whole
        raw = getattr(msg, "_text_raw", None)
        chunk = raw.split(b"\0", 1)[0] if isinstance(raw, bytes) else str(msg.text).encode()
        text_id = int(getattr(msg, "id", 0))  # MAVLink 1 has no chunks
        if text_id:
            key = (msg.get_srcSystem(), text_id)
            chunks = self._texts.pop(key, [])
            chunks.append(chunk)
            if len(chunk) >= _TEXT_CHUNK:  # more to come
                self._texts[key] = chunks
                while len(self._texts) > _TEXTS_PENDING:
                    del self._texts[next(iter(self._texts))]
                return []
            chunk = b"".join(chunks)
        if not 0 <= msg.severity <= _SEVERITY_MAX:  # a corrupt message
            self.rejected["STATUSTEXT"] += 1
            return []
        return [VehicleText(t_s, int(msg.severity), chunk.decode("utf-8", errors="replace"))]

    def _attitude(self, msg: MavMessage, t_s: float) -> Attitude | None:
        return checked_attitude(t_s, msg.roll, msg.pitch, msg.yaw, msg.rollspeed,
                                msg.pitchspeed, msg.yawspeed)

    def _servo(self, msg: MavMessage, t_s: float) -> Thrusters | _Skip | None:
        base = 16 * int(msg.port)
        for k in range(1, 17):
            self._outputs[base + k] = int(getattr(msg, f"servo{k}_raw"))
        outputs = [self.params.output_of(c) for c in self.channels or self.params.motors()]
        if not any(base < o <= base + 16 for o in outputs):
            return _SKIP
        return checked_thrusters(t_s, (self._outputs.get(o, 0) for o in outputs))

    def _vfr_hud(self, msg: MavMessage, t_s: float) -> Depth | None:
        return checked_depth(t_s, -float(msg.alt))

    def _global_position(self, msg: MavMessage, t_s: float) -> Depth | None:
        return checked_depth(t_s, -msg.relative_alt / 1000.0)

    def _pressure(self, msg: MavMessage, t_s: float) -> Depth | None:
        p_surface = self.surface_pressure_Pa or self.params.surface_pressure_Pa
        p = float(msg.press_abs) * 100.0  # hPa → Pa
        if p_surface is None or not _ok(p, "pressure_Pa"):
            return None
        return checked_depth(t_s, (p - p_surface) / self.rho_g)

    def _odometry(self, msg: MavMessage, t_s: float) -> Velocity | _Skip | None:
        if int(msg.child_frame_id) != _FRAME_BODY_FRD:
            return _SKIP
        u, v, w = float(msg.vx), float(msg.vy), float(msg.vz)
        return Velocity(t_s, u, v, w) if all(_ok(x, "speed_m_s") for x in (u, v, w)) else None

    def _sys_status(self, msg: MavMessage, t_s: float) -> Battery | None:
        mv = int(msg.voltage_battery)
        return None if mv == _UINT16_MAX else checked_battery(t_s, mv / 1000.0)

    def _battery_status(self, msg: MavMessage, t_s: float) -> Battery | _Skip | None:
        if int(msg.id) != 0:
            return _SKIP
        cells = [v for v in msg.voltages if v != _UINT16_MAX]
        return checked_battery(t_s, sum(cells) / 1000.0) if cells else None
