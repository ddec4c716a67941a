"""A pymavlink ground station against the simulator served as ArduSub over UDP loopback.

The station drives the server in lockstep (:class:`GroundStation`): the vehicle's clock
moves only while the station waits for a message, so the station answers at the same
simulated moments however busy the machine is (served in real time, a station held up
for 0.3 s missed the pilot-input failsafe's 3 s at 10×). Everything is judged on the
vehicle's own time stamps (``time_boot_ms``), never on the wall clock; the wall-clock
limit only keeps a broken server from hanging the suite. (Real-time serving,
:meth:`MavlinkServer.run`, is what ``tests/drivers/test_mavlink_link.py`` and
``test_mavlink_stations.py`` run.)
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from trimd.core.errors import LinkError
from trimd.core.model import quaternion_from_euler
from trimd.core.profile import Profile
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.mavlink_server import MavlinkServer, open_mavlink2
from trimd.drivers.sim.vehicle import SimVehicle

STEP_S = 0.05          # simulated time the server advances while nothing waits [s]
SIM_LIMIT_S = 600.0    # no answer in this much simulated time: the server is broken
WALL_LIMIT_S = 300.0   # a hang guard, not a timed assertion


class GroundStation:
    """A pymavlink GCS (sysid 255) that sees the vehicle's simulated time and paces the
    server: whenever no message waits on its socket, it advances :attr:`server` by
    STEP_S of simulated time (which hands the server what the station sent, and sends
    what falls due)."""

    def __init__(self) -> None:
        self.conn = open_mavlink2("udpin:127.0.0.1:0", 255, 190)
        self.port = self.conn.port.getsockname()[1]
        self.server: MavlinkServer | None = None
        self.t = 0.0
        self.seen: list[tuple[float, Any]] = []
        self._deadline = time.monotonic() + WALL_LIMIT_S

    def messages(self) -> Iterator[Any]:
        assert self.server is not None
        vehicle = self.server.vehicle
        while True:
            if time.monotonic() > self._deadline:
                raise AssertionError("hang guard: the test did not end within "
                                     f"{WALL_LIMIT_S:g} s of wall clock")
            msg = self.conn.recv_match(blocking=False)
            if msg is None:
                if vehicle.t_s > SIM_LIMIT_S:
                    raise AssertionError("the served simulator stopped answering")
                self.server.advance_to(vehicle.t_s + STEP_S)
                continue
            if hasattr(msg, "time_boot_ms"):
                self.t = msg.time_boot_ms / 1000
            self.seen.append((self.t, msg))
            yield msg

    def run_until(self, t_end: float, every: Callable[[], None] | None = None,
                  period: float = 0.2) -> list[tuple[float, Any]]:
        """Receive until the vehicle's time reaches ``t_end``, calling ``every`` each
        ``period`` of vehicle time; return what arrived."""
        start, next_call = len(self.seen), self.t
        for _ in self.messages():
            if every is not None and self.t >= next_call:
                every()
                next_call = self.t + period
            if self.t >= t_end:
                break
        return self.seen[start:]

    def command(self, command: int, *params: float) -> Any:
        p = [*params, 0, 0, 0, 0, 0, 0, 0][:7]
        self.conn.mav.command_long_send(1, 1, command, 0, *p)
        for msg in self.messages():
            if msg.get_type() == "COMMAND_ACK" and msg.command == command:
                return msg
        raise AssertionError("unreachable")

    def param(self, name: str) -> float:
        self.conn.mav.param_request_read_send(1, 1, name.encode(), -1)
        for msg in self.messages():
            if msg.get_type() == "PARAM_VALUE" and msg.param_id == name:
                return float(msg.param_value)
        raise AssertionError("unreachable")


def _rate(received: list[tuple[float, Any]], kind: str) -> float:
    """Messages of ``kind`` per second of vehicle time."""
    times = [t for t, m in received if m.get_type() == kind]
    span = received[-1][0] - received[0][0]
    return len(times) / span


@pytest.fixture()
def served(bluerov: Profile) -> Iterator[tuple[GroundStation, SimVehicle]]:
    gcs = GroundStation()
    vehicle = SimVehicle(bluerov, SimConfig(payload="0.4@W-aft-ctr", armed=False,
                                            mode="MANUAL", seed=1))
    gcs.server = MavlinkServer(vehicle, f"udpout:127.0.0.1:{gcs.port}")
    yield gcs, vehicle
    gcs.server.close()
    gcs.conn.close()


def test_ground_station_sees_ardusub_and_holds_an_attitude(
        served: tuple[GroundStation, SimVehicle]) -> None:
    gcs, vehicle = served
    c = gcs.conn.mav
    from pymavlink.dialects.v20 import ardupilotmega as m

    # telemetry at ArduSub's default rates, as a disarmed submarine in MANUAL
    got = gcs.run_until(10.0)
    beats = [msg for _, msg in got if msg.get_type() == "HEARTBEAT"]
    assert {(b.type, b.autopilot, b.custom_mode) for b in beats} == {(12, 3, 19)}
    assert not any(b.base_mode & 128 for b in beats)
    assert _rate(got, "HEARTBEAT") == pytest.approx(1.0, rel=0.15)
    assert _rate(got, "ATTITUDE") == pytest.approx(10.0, rel=0.1)
    assert _rate(got, "SERVO_OUTPUT_RAW") == pytest.approx(2.0, rel=0.2)
    servo = next(msg for _, msg in got if msg.get_type() == "SERVO_OUTPUT_RAW")
    assert [servo.servo1_raw, servo.servo8_raw, servo.servo9_raw] == [1500, 1500, 0]
    depth = [msg.relative_alt for _, msg in got if msg.get_type() == "GLOBAL_POSITION_INT"]
    assert abs(depth[0] + 5000) < 50 and depth[-1] < depth[0] - 100   # heavy: it sinks

    # re-rate the thruster outputs; read the parameters a driver needs
    ack = gcs.command(m.MAV_CMD_SET_MESSAGE_INTERVAL, 36, 100_000)
    assert ack.result == m.MAV_RESULT_ACCEPTED
    assert _rate(gcs.run_until(gcs.t + 5.0), "SERVO_OUTPUT_RAW") == pytest.approx(10, rel=0.15)
    assert [gcs.param(n) for n in ("FRAME_CONFIG", "SERVO1_FUNCTION", "SERVO8_FUNCTION",
                                   "MOT_1_DIRECTION")] == [2, 33, 40, 1]

    # arm, ALT_HOLD (GUIDED refused), neutral pilot input, and an attitude target
    assert gcs.command(m.MAV_CMD_DO_SET_MODE, 1, 4).result == m.MAV_RESULT_DENIED
    assert gcs.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == m.MAV_RESULT_ACCEPTED
    assert gcs.command(m.MAV_CMD_DO_SET_MODE, 1, 2).result == m.MAV_RESULT_ACCEPTED
    target = (math.radians(10), math.radians(15), 0.5)

    def pilot() -> None:
        c.manual_control_send(1, 0, 0, 500, 0, 0)

    def pilot_and_target() -> None:
        pilot()
        c.set_attitude_target_send(0, 1, 1, 64 | 7, quaternion_from_euler(*target), 0, 0, 0, 0)

    held = gcs.run_until(gcs.t + 30.0, pilot_and_target)
    beats = [msg for _, msg in held if msg.get_type() == "HEARTBEAT"]
    assert beats[-1].custom_mode == 2 and beats[-1].base_mode & 128
    late = [msg for t, msg in held if msg.get_type() == "ATTITUDE" and t > held[-1][0] - 5]
    for msg in late:
        assert abs(msg.roll - target[0]) < math.radians(1)
        assert abs(msg.pitch - target[1]) < math.radians(1)
        assert abs(msg.yaw - target[2]) < math.radians(2)

    # the target holds for 5 s after the last one, then the pilot's neutral (level) takes
    # over (slowly: the integrators must carry the front thrusters across the deadband)
    t_last = gcs.t
    after = gcs.run_until(gcs.t + 30.0, pilot)
    still = [msg for t, msg in after if msg.get_type() == "ATTITUDE" and t < t_last + 4.5]
    assert all(abs(msg.pitch - target[1]) < math.radians(1) for msg in still)
    late = [msg for t, msg in after if msg.get_type() == "ATTITUDE" and t > after[-1][0] - 3]
    assert all(abs(msg.roll) < math.radians(1.5) and abs(msg.pitch) < math.radians(1.5)
               for msg in late)
    assert vehicle.armed

    # pilot input from another system id does not count: failsafe disarm after 3 s
    def stranger() -> None:
        gcs.conn.mav.srcSystem = 42
        pilot()
        gcs.conn.mav.srcSystem = 255

    t_last = gcs.t
    tail = gcs.run_until(gcs.t + 5.0, stranger)
    beats = [(t, msg) for t, msg in tail if msg.get_type() == "HEARTBEAT"]
    armed_until = max(t for t, b in beats if b.base_mode & 128)
    assert 2.0 <= armed_until - t_last <= 3.5
    assert not beats[-1][1].base_mode & 128
    assert any(msg.get_type() == "STATUSTEXT" and "Failsafe" in msg.text for _, msg in tail)

    # FS_PILOT_INPUT = 0 (PARAM_SET, confirmed by PARAM_VALUE) switches the failsafe off
    c.param_set_send(1, 1, b"FS_PILOT_INPUT", 0, m.MAV_PARAM_TYPE_INT8)
    assert next(msg.param_value for msg in gcs.messages() if msg.get_type() == "PARAM_VALUE"
                and msg.param_id == "FS_PILOT_INPUT") == 0
    assert gcs.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == m.MAV_RESULT_ACCEPTED
    quiet = gcs.run_until(gcs.t + 5.0)
    assert all(msg.base_mode & 128 for _, msg in quiet if msg.get_type() == "HEARTBEAT")


def test_refuses_a_device_pymavlink_would_take_for_a_serial_port(bluerov: Profile) -> None:
    with pytest.raises(LinkError, match="udpout"):
        MavlinkServer(SimVehicle(bluerov), "udp:127.0.0.1:14550")


def test_parameters_follow_the_channels_whatever_the_thruster_order(bluerov: Profile) -> None:
    """Motor n sits on output n (the driver's reading of a channel): listing the thrusters
    in another order, with one reversed, changes nothing but that motor's direction."""
    last = dataclasses.replace(bluerov.thrusters[-1], reversed=True)
    shuffled = dataclasses.replace(bluerov, thrusters=(last, *bluerov.thrusters[:-1]))
    server = MavlinkServer(SimVehicle(shuffled), "udpout:127.0.0.1:9")
    try:
        params = {k: v for k, (v, _) in server._params.items()}
        assert [params[f"SERVO{n}_FUNCTION"] for n in range(1, 10)] == [
            33, 34, 35, 36, 37, 38, 39, 40, 0]
        assert [params[f"MOT_{n}_DIRECTION"] for n in range(1, 9)] == [1] * 7 + [-1]
    finally:
        server.close()
