"""The simulated vehicle served as an ArduSub autopilot over MAVLink 2 (pymavlink).

What a ground station sees (``docs/ardusub.md``): HEARTBEAT as MAV_TYPE_SUBMARINE
from an ArduPilot autopilot (sysid 1, compid 1) with the ArduSub mode number and the armed
bit; ATTITUDE (stream EXTRA1, 10 Hz), VFR_HUD (EXTRA2, 10 Hz), SERVO_OUTPUT_RAW (RC_CHAN,
2 Hz), SCALED_PRESSURE2 (RAW_SENS, 2 Hz; the external depth sensor), GLOBAL_POSITION_INT
(POSITION, 3 Hz; relative_alt = −depth) and SYS_STATUS (EXT_STAT, 2 Hz; battery voltage),
re-rated by MAV_CMD_SET_MESSAGE_INTERVAL or REQUEST_DATA_STREAM: the last request wins,
whoever sent it (ArduPilot behind BlueOS's router: one channel for every ground station).

Several endpoints (``devices``) make it ArduSub behind BlueOS's MAVLink router: the
vehicle's messages go to every endpoint, and each packet received on one endpoint is
passed on to the others (so ground stations see each other's heartbeats and stick input)
before the vehicle acts on it; COMMAND_ACK names the sender it answers (target_system,
target_component).

What it obeys: MAV_CMD_COMPONENT_ARM_DISARM; MAV_CMD_DO_SET_MODE and SET_MODE for MANUAL,
STABILIZE and ALT_HOLD (other modes are denied: GUIDED needs a position estimate); in
ALT_HOLD, SET_ATTITUDE_TARGET with the throttle-ignore bit (64) holds that attitude (roll,
pitch, absolute yaw) until 5 s after the last such message; MANUAL_CONTROL (z = 500
neutral) from the GCS system id (SYSID_MYGCS = 255) on any endpoint, whichever station
sent it (the last one wins, as in ArduSub); without pilot input for FS_PILOT_TIMEOUT
(3 s) an armed vehicle disarms (FS_PILOT_INPUT = 2; 0 turns the failsafe off);
PARAM_REQUEST_READ / PARAM_REQUEST_LIST for FRAME_CONFIG, SERVOn_FUNCTION,
MOT_n_DIRECTION and the failsafe parameters, and PARAM_SET for the failsafe parameters.

Every time (stream schedules, the 5 s and 3 s timeouts, ``time_boot_ms``) is simulated
time; only :meth:`MavlinkServer.run` paces simulated time against the wall clock (real
time, or ``rate`` times faster). The server talks to the vehicle only through the
:class:`~trimd.drivers.sim.vehicle.SimVehicle` API, which a serial server can reuse.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.errors import LinkError
from trimd.core.samples import Attitude, Depth
from trimd.drivers.mavlink.ardusub import mode_name, mode_number
from trimd.drivers.mavlink.decode import motor_function
from trimd.drivers.mavlink.message import MavConnection, MavMessage, speak_mavlink2
from trimd.drivers.sim.controller import MODES
from trimd.drivers.sim.dynamics import euler_from_quaternion
from trimd.drivers.sim.pacing import run_paced
from trimd.drivers.sim.vehicle import SimVehicle

__all__ = ["DEFAULT_STREAM_HZ", "STREAMS", "MavlinkServer", "open_mavlink2"]

#: ArduSub stream id → the messages this simulator sends in it.
STREAMS: dict[int, tuple[str, ...]] = {
    1: ("SCALED_PRESSURE2",), 2: ("SYS_STATUS",), 3: ("SERVO_OUTPUT_RAW",),
    6: ("GLOBAL_POSITION_INT",), 10: ("ATTITUDE",), 11: ("VFR_HUD",),
}
#: ArduSub's default stream rates [Hz].
DEFAULT_STREAM_HZ = {1: 2.0, 2: 2.0, 3: 2.0, 6: 3.0, 10: 10.0, 11: 10.0}

_ATTITUDE_TARGET_TIMEOUT_S = 5.0
_PILOT_TIMEOUT_S = 3.0
_SETTABLE = ("FS_PILOT_INPUT", "FS_PILOT_TIMEOUT")  # PARAM_SET takes these
_POLL_S = 0.25          # longest simulated time between two looks at the endpoints
_GCS_SYSID = 255
_THROTTLE_IGNORE = 64
_TRANSPORTS = ("udpin:", "udpout:", "tcpin:", "tcp:")


def open_mavlink2(device: str, sysid: int, compid: int) -> MavConnection:
    """A pymavlink connection that speaks MAVLink 2 with the ardupilotmega dialect from
    the first byte (pinned here, not through the MAVLINK20 environment variable).

    Only network transports are accepted: pymavlink would open a serial port for anything
    it does not recognise.
    """
    if not device.startswith(_TRANSPORTS):
        raise LinkError(f"cannot serve MAVLink on '{device}': use udpout:HOST:PORT, "
                        "udpin:HOST:PORT, tcpin:HOST:PORT or tcp:HOST:PORT")
    return speak_mavlink2(mavutil.mavlink_connection(
        device, source_system=sysid, source_component=compid, dialect="ardupilotmega"),
        sysid, compid)


class _Fanout:
    """The vehicle's output: every packet to every endpoint (pymavlink's ``file``)."""

    def __init__(self, conns: list[MavConnection]) -> None:
        self.conns = conns

    def write(self, buf: bytes) -> None:
        for conn in self.conns:
            conn.write(buf)


class MavlinkServer:
    """Serve ``vehicle`` on ``devices`` (pymavlink network device strings; several:
    behind a router, module docstring).

    Parameters
    ----------
    vehicle : the simulated vehicle (ArduSub boots disarmed in MANUAL: configure it so).
    devices : ``udpout:127.0.0.1:14550``, ``udpin:0.0.0.0:14550``, ``tcpin:0.0.0.0:5760``…
    rate : simulated seconds per wall second in :meth:`run`.
    """

    def __init__(self, vehicle: SimVehicle, devices: str | Sequence[str], *,
                 rate: float = 1.0) -> None:
        if not rate > 0:
            raise ValueError(f"rate must be positive, got {rate}")
        self.vehicle = vehicle
        self.rate = rate
        self.conns: list[MavConnection] = []
        try:
            for device in [devices] if isinstance(devices, str) else devices:
                self.conns.append(open_mavlink2(device, 1, 1))
        except BaseException:
            self.close()
            raise
        self.mav = mavlink2.MAVLink(_Fanout(self.conns), srcSystem=1, srcComponent=1)
        self.intervals: dict[str, float] = {"HEARTBEAT": 1.0}
        for stream, hz in DEFAULT_STREAM_HZ.items():
            self._set_stream(stream, hz)
        self._due: dict[str, float] = {}
        self._params = self._parameters()
        self._attitude_target_t = math.nan
        self._pilot_t = vehicle.t_s

    # ------------------------------------------------------------------ running
    def run(self, stop: threading.Event | None = None, duration_s: float = math.inf) -> None:
        """Serve until ``stop`` is set or ``duration_s`` of simulated time has passed."""
        run_paced(self.vehicle, self.advance_to, [c.fd for c in self.conns], rate=self.rate,
                  stop=stop, duration_s=duration_s)
        self.close()

    def close(self) -> None:
        """Close every endpoint."""
        for conn in self.conns:
            conn.close()

    def advance_to(self, t_s: float) -> None:
        """Handle what arrived, then step the vehicle to simulated time ``t_s`` [s],
        applying the timeouts and sending each message when it is due."""
        self.poll()
        v = self.vehicle
        t_polled = v.t_s
        while v.t_s + 0.5 * v.dt_s < t_s:
            if v.t_s - t_polled >= _POLL_S:  # catching up after a stall: what arrived
                self.poll()                   # meanwhile counts before any timeout
                t_polled = v.t_s
            v.step()
            self._timeouts()
            self._send_due()

    def poll(self) -> None:
        """Handle every message waiting on the endpoints, after passing it on to the
        other endpoints."""
        for conn in self.conns:
            while (msg := conn.recv_msg()) is not None:
                if msg.get_type() == "BAD_DATA":
                    continue
                for other in self.conns:
                    if other is not conn:
                        other.write(msg.get_msgbuf())
                self.handle(msg)

    def _timeouts(self) -> None:
        v, t = self.vehicle, self.vehicle.t_s
        if t - self._attitude_target_t > _ATTITUDE_TARGET_TIMEOUT_S:
            self._attitude_target_t = math.nan
            v.level()
        failsafe, timeout = self._params["FS_PILOT_INPUT"][0], self._params[
            "FS_PILOT_TIMEOUT"][0]
        if v.armed and failsafe and t - self._pilot_t > timeout:
            v.arm(False)
            self._statustext("Failsafe: pilot input lost, disarming")

    def _send_due(self) -> None:
        t = self.vehicle.t_s
        for name, interval in self.intervals.items():
            due = self._due.get(name, t)
            if t + 1e-9 >= due:
                getattr(self, f"_send_{name.lower()}")()
                self._due[name] = due + interval if due + interval > t else t + interval

    # ------------------------------------------------------------------ incoming
    def handle(self, msg: MavMessage) -> None:
        """Act on one received message (ArduSub's behaviour, module docstring)."""
        kind = msg.get_type()
        if kind == "COMMAND_LONG":
            self._command(msg)
        elif kind == "SET_MODE":
            self._set_mode(int(msg.custom_mode))
        elif kind == "SET_ATTITUDE_TARGET":
            if self.vehicle.mode == "ALT_HOLD" and msg.type_mask & _THROTTLE_IGNORE:
                phi, theta, psi = euler_from_quaternion(*msg.q)
                self.vehicle.hold_attitude(phi, theta, psi)
                self._attitude_target_t = self.vehicle.t_s
        elif kind == "MANUAL_CONTROL":
            if msg.get_srcSystem() == _GCS_SYSID:
                self.vehicle.pilot(msg.x / 1000, msg.y / 1000, (msg.z - 500) / 500, msg.r / 1000)
                self._pilot_t = self.vehicle.t_s
        elif kind == "REQUEST_DATA_STREAM":
            streams = STREAMS if msg.req_stream_id == 0 else [msg.req_stream_id]
            for stream in streams:
                self._set_stream(stream, msg.req_message_rate if msg.start_stop else 0.0)
        elif kind == "PARAM_REQUEST_READ":
            names = list(self._params)
            name = msg.param_id if msg.param_index < 0 else (
                names[msg.param_index] if msg.param_index < len(names) else "")
            if name in self._params:
                self._param_value(name)
        elif kind == "PARAM_SET" and msg.param_id in _SETTABLE:
            _, kind_id = self._params[msg.param_id]
            self._params[msg.param_id] = (float(msg.param_value), kind_id)
            self._param_value(msg.param_id)
        elif kind == "PARAM_REQUEST_LIST":
            for name in self._params:
                self._param_value(name)

    def _command(self, msg: MavMessage) -> None:
        c = mavlink2
        result = c.MAV_RESULT_ACCEPTED
        if msg.command == c.MAV_CMD_COMPONENT_ARM_DISARM:
            armed = msg.param1 >= 0.5
            if armed and not self.vehicle.armed:
                self._pilot_t = self.vehicle.t_s
            self.vehicle.arm(armed)
        elif msg.command == c.MAV_CMD_DO_SET_MODE:
            result = self._set_mode(int(msg.param2))
        elif msg.command == c.MAV_CMD_SET_MESSAGE_INTERVAL:
            result = self._set_interval(int(msg.param1), msg.param2)
        else:
            result = c.MAV_RESULT_UNSUPPORTED
        self.mav.command_ack_send(msg.command, result, 0, 0, msg.get_srcSystem(),
                                  msg.get_srcComponent())

    def _set_mode(self, number: int) -> int:
        name = mode_name(number)
        if name not in MODES:
            self._statustext(f"Mode change to {name} denied by the simulator")
            return int(mavlink2.MAV_RESULT_DENIED)
        if name != self.vehicle.mode:
            self._attitude_target_t = math.nan
        self.vehicle.set_mode(name)
        return int(mavlink2.MAV_RESULT_ACCEPTED)

    def _set_interval(self, msg_id: int, interval_us: float) -> int:
        entry = mavlink2.mavlink_map.get(msg_id)
        name = str(entry.msgname) if entry is not None else ""
        if not hasattr(self, f"_send_{name.lower()}"):
            return int(mavlink2.MAV_RESULT_UNSUPPORTED)
        if interval_us == 0:
            stream = next((s for s, m in STREAMS.items() if name in m), None)
            interval_us = 1e6 / DEFAULT_STREAM_HZ[stream] if stream is not None else 1e6
        if interval_us < 0:
            self.intervals.pop(name, None)
        else:
            self.intervals[name] = interval_us / 1e6
            self._due[name] = self.vehicle.t_s
        return int(mavlink2.MAV_RESULT_ACCEPTED)

    def _set_stream(self, stream: int, hz: float) -> None:
        for name in STREAMS.get(stream, ()):
            if hz > 0:
                self.intervals[name] = 1.0 / hz
            else:
                self.intervals.pop(name, None)

    # ------------------------------------------------------------------ parameters
    def _parameters(self) -> dict[str, tuple[float, int]]:
        """Name → (value, MAV_PARAM_TYPE) of the parameters a ground station may read."""
        v = self.vehicle
        int8, int16, real = (mavlink2.MAV_PARAM_TYPE_INT8, mavlink2.MAV_PARAM_TYPE_INT16,
                             mavlink2.MAV_PARAM_TYPE_REAL32)
        frame = v.profile.frame_config
        params: dict[str, tuple[float, int]] = {
            "FRAME_CONFIG": (float(7 if frame is None else frame), int8),
            "SYSID_MYGCS": (float(_GCS_SYSID), int16),
            "FS_PILOT_INPUT": (2.0, int8), "FS_PILOT_TIMEOUT": (_PILOT_TIMEOUT_S, real),
            "MOT_PWM_MIN": (float(v.mixer.ranges[0][0]), int16),
            "MOT_PWM_MAX": (float(v.mixer.ranges[0][1]), int16),
        }
        # a profile's channel is the ArduSub motor number (motor n on output n, as the
        # driver reads it), whatever order the profile lists the thrusters in
        channels = {t.channel for t in v.profile.thrusters}
        for n in range(1, 17):
            function = motor_function(n) if n in channels else 0
            params[f"SERVO{n}_FUNCTION"] = (float(function), int16)
        for t in v.profile.thrusters:
            params[f"MOT_{t.channel}_DIRECTION"] = (-1.0 if t.reversed else 1.0, int8)
        return params

    def _param_value(self, name: str) -> None:
        value, kind = self._params[name]
        names = list(self._params)
        self.mav.param_value_send(name.encode(), value, kind, len(names),
                                       names.index(name))

    # ------------------------------------------------------------------ outgoing
    def _statustext(self, text: str) -> None:
        self.mav.statustext_send(mavlink2.MAV_SEVERITY_CRITICAL, text.encode()[:50])

    def _ms(self) -> int:
        return round(self.vehicle.t_s * 1000)

    def _send_heartbeat(self) -> None:
        v = self.vehicle
        base = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
            mavlink2.MAV_MODE_FLAG_SAFETY_ARMED if v.armed else 0)
        status = mavlink2.MAV_STATE_ACTIVE if v.armed else mavlink2.MAV_STATE_STANDBY
        self.mav.heartbeat_send(mavlink2.MAV_TYPE_SUBMARINE,
                                     mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                                     mode_number(v.mode), status)

    def _attitude(self) -> Attitude:
        a = self.vehicle.sample("attitude")
        assert isinstance(a, Attitude)
        return a

    def _depth(self) -> float:
        d = self.vehicle.sample("depth")
        assert isinstance(d, Depth)
        return d.depth_m

    def _send_attitude(self) -> None:
        a = self._attitude()
        self.mav.attitude_send(self._ms(), a.phi, a.theta, a.psi, a.p, a.q, a.r)

    def _send_servo_output_raw(self) -> None:
        raw = [0] * 16
        for t, pwm in zip(self.vehicle.profile.thrusters, self.vehicle.thrusters.reported_us,
                          strict=True):
            if t.channel <= 16:
                raw[t.channel - 1] = pwm
        self.mav.servo_output_raw_send(self._ms() * 1000, 0, *raw)

    def _send_scaled_pressure2(self) -> None:
        p = self.vehicle.profile
        press_pa = 101325.0 + p.water_density_kg_m3 * p.gravity_m_s2 * self._depth()
        self.mav.scaled_pressure2_send(self._ms(), press_pa / 100.0, 0.0, 1500)

    def _send_global_position_int(self) -> None:
        depth_mm = round(self._depth() * 1000)
        heading = round(math.degrees(self._attitude().psi) * 100) % 36000
        self.mav.global_position_int_send(self._ms(), 0, 0, -depth_mm, -depth_mm, 0, 0, 0,
                                               heading)

    def _send_vfr_hud(self) -> None:
        heading = round(math.degrees(self._attitude().psi)) % 360
        climb = -self.vehicle.reading.depth_rate_m_s
        self.mav.vfr_hud_send(0.0, 0.0, heading, 0, -self._depth(), climb)

    def _send_sys_status(self) -> None:
        mv = round(self.vehicle.voltage_V * 1000)
        self.mav.sys_status_send(0, 0, 0, 0, mv, -1, -1, 0, 0, 0, 0, 0, 0)
