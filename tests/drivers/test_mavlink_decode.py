"""MAVLink message → typed sample conversions, each against hand-computed numbers."""

from __future__ import annotations

import math
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.profile import Profile
from trimd.core.samples import (
    Attitude,
    Battery,
    Depth,
    Health,
    ModeClass,
    Thrusters,
    VehicleText,
)
from trimd.drivers.mavlink.decode import MavlinkDecoder, VehicleParams, motor_function

SUB, ARDUPILOT, GCS, INVALID = 12, 3, 6, 8
ARMED_MANUAL = 128 | 81


def packet(build: Any, sysid: int = 1, compid: int = 1) -> Any:
    """A message that went through the wire (so its header carries the sender)."""
    mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    return mavlink2.MAVLink(None).decode(bytearray(build(mav).pack(mav)))


def heartbeat(custom_mode: int = 19, base_mode: int = 81, sysid: int = 1, compid: int = 1,
              mav_type: int = SUB, autopilot: int = ARDUPILOT) -> Any:
    return packet(lambda m: m.heartbeat_encode(mav_type, autopilot, base_mode, custom_mode, 4),
                  sysid, compid)


def bound(channels: tuple[int, ...] | None = (1, 2, 3), **options: Any) -> MavlinkDecoder:
    d = MavlinkDecoder(channels, **options)
    assert len(d.decode(heartbeat(), 0.0)) == 1
    return d


def servo(values: dict[int, int], port: int = 0) -> Any:
    raw = [values.get(k, 0) for k in range(1, 17)]
    return packet(lambda m: m.servo_output_raw_encode(0, port, *raw))


def test_heartbeat_only_from_the_autopilot_gives_mode_and_armed() -> None:
    d = MavlinkDecoder((1,))
    assert d.decode(heartbeat(mav_type=GCS, autopilot=INVALID, sysid=255, compid=190), 0) == []
    assert d.decode(heartbeat(mav_type=30, autopilot=INVALID, compid=100), 0) == []
    assert d.vehicle is None
    assert d.decode(heartbeat(21, ARMED_MANUAL), 1.5) == [
        Health(1.5, True, "SURFTRAK", True, vehicle="sysid 1 ArduPilot submarine",
               mode_class=ModeClass.AUTONOMOUS)]
    assert d.vehicle == (1, 1)
    [h] = d.decode(heartbeat(20, 81), 2.0)
    assert (h.mode, h.armed) == ("MOTOR_DETECT", False)
    assert d.decode(heartbeat(2, ARMED_MANUAL, sysid=2), 3.0) == []  # another vehicle
    assert d.ignored == 3


def test_vehicle_is_named_by_sysid_autopilot_and_type() -> None:
    [h] = MavlinkDecoder((1,)).decode(heartbeat(sysid=7, mav_type=2, autopilot=12), 0.0)
    assert h.vehicle == "sysid 7 PX4 quadrotor"
    [h] = MavlinkDecoder((1,)).decode(heartbeat(mav_type=250, autopilot=99), 0.0)
    assert h.vehicle == "sysid 1 autopilot 99 type 250"


def statustext(text: bytes, severity: int = 2, text_id: int = 0, seq: int = 0,
               sysid: int = 1, compid: int = 1) -> Any:
    return packet(lambda m: m.statustext_encode(severity, text, text_id, seq), sysid, compid)


def test_statustext_of_the_vehicle_becomes_a_vehicle_text() -> None:
    d = MavlinkDecoder((1,))
    # the boot banner comes before the first heartbeat: it follows that heartbeat
    assert d.decode(statustext(b"ArduSub V4.1.1", 6), 0.5) == []
    assert d.decode(statustext(b"a GCS before the vehicle", sysid=255, compid=190), 0.6) == []
    health, banner = d.decode(heartbeat(), 1.0)
    assert isinstance(health, Health) and banner == VehicleText(0.5, 6, "ArduSub V4.1.1")
    assert d.decode(statustext(b"Failsafe: pilot input lost, disarming"), 2.0) == [
        VehicleText(2.0, 2, "Failsafe: pilot input lost, disarming")]
    # any component of the vehicle's system (a camera, the companion computer) …
    [t] = d.decode(statustext(b"camera ready", 6, compid=100), 2.5)
    assert (t.severity, t.level, t.text) == (6, "info", "camera ready")
    # … but nothing from another system (the GCS, another vehicle)
    assert d.decode(statustext(b"from the GCS", sysid=255, compid=190), 3.0) == []
    assert d.ignored == 1
    assert d.decode(statustext(b"severity 9 is corrupt", 9), 3.5) == []
    assert d.rejected["STATUSTEXT"] == 1


def test_chunked_statustext_is_joined() -> None:
    d = bound()
    long = "PreArm: " + "0123456789" * 9  # 98 bytes: chunks of 50 and 48
    assert d.decode(statustext(long[:50].encode(), 4, text_id=7, seq=0), 1.0) == []
    [t] = d.decode(statustext(long[50:].encode(), 4, text_id=7, seq=1), 1.1)
    assert (t.t_s, t.text, t.level) == (1.1, long, "warning")
    exact = "x" * 50  # a full last chunk is followed by an empty one
    assert d.decode(statustext(exact.encode(), 4, text_id=8, seq=0), 2.0) == []
    assert d.decode(statustext(b"", 4, text_id=8, seq=1), 2.1)[0].text == exact


def test_sysid_chooses_the_vehicle() -> None:
    d = MavlinkDecoder((1,), sysid=7)
    assert d.decode(heartbeat(sysid=1), 0) == []
    assert d.decode(heartbeat(2, sysid=7), 0)[0].mode == "ALT_HOLD"


def test_attitude_is_taken_as_is_in_rad_and_rad_per_s() -> None:
    msg = packet(lambda m: m.attitude_encode(0, 0.25, -0.5, 3.0, 0.125, -0.0625, 1.5))
    assert MavlinkDecoder((1,)).decode(msg, 1.0) == []  # no vehicle yet
    [a] = bound().decode(msg, 1.0)
    assert a == Attitude(1.0, 0.25, -0.5, 3.0, 0.125, -0.0625, 1.5)  # exact in float32


@pytest.mark.parametrize("values", [
    (math.nan, 0, 0, 0, 0, 0), (0, 2.0, 0, 0, 0, 0), (3.2, 0, 0, 0, 0, 0),
    (0, 0, 0, math.inf, 0, 0), (0, 0, 0, 0, 0, -40.0)])
def test_attitude_out_of_range_is_counted_not_yielded(values: tuple[float, ...]) -> None:
    d = bound()
    assert d.decode(packet(lambda m: m.attitude_encode(0, *values)), 1.0) == []
    assert d.rejected["ATTITUDE"] == 1


def test_attitude_of_another_system_is_ignored() -> None:
    d = bound()
    assert d.decode(packet(lambda m: m.attitude_encode(0, 0, 0, 0, 0, 0, 0), sysid=2), 1) == []
    assert d.ignored == 1 and not d.rejected


def test_servo_outputs_follow_the_profile_channels() -> None:
    d = bound((5, 1, 2))
    [t] = d.decode(servo({1: 1100, 2: 1200, 5: 1900, 9: 1234}), 2.0)
    assert t == Thrusters(2.0, (1900.0, 1100.0, 1200.0))


def test_servo_function_remaps_a_motor_to_another_output() -> None:
    d = bound((1, 2))
    for name, value in (("SERVO1_FUNCTION", 0), ("SERVO9_FUNCTION", 33),
                        ("SERVO2_FUNCTION", 34)):
        d.decode(packet(lambda m, n=name, v=value: m.param_value_encode(n.encode(), v, 9, 900, 0)),
                 0)
    [t] = d.decode(servo({1: 1500, 2: 1600, 9: 1700}), 1.0)
    assert t.pwm_us == (1700.0, 1600.0)  # motor 1 now comes from output 9


def test_servo_channels_on_the_second_port() -> None:
    d = bound((1, 17))
    assert d.decode(servo({1: 1400}), 1.0) == []  # output 17 not seen yet
    assert d.rejected["SERVO_OUTPUT_RAW"] == 1
    assert d.decode(servo({1: 1600}, port=1), 1.1) == [Thrusters(1.1, (1400.0, 1600.0))]


def test_servo_zero_on_a_thruster_channel_is_rejected() -> None:
    d = bound((1, 2, 3))
    assert d.decode(servo({1: 1500, 2: 1500}), 1.0) == []
    assert d.rejected["SERVO_OUTPUT_RAW"] == 1


def test_without_channels_the_vehicle_motors_are_read() -> None:
    d = bound(None)
    for n in range(1, 7):
        d.decode(packet(lambda m, n=n: m.param_value_encode(
            f"SERVO{n}_FUNCTION".encode(), 32 + n, 9, 900, 0)), 0)
    [t] = d.decode(servo({k: 1500 + k for k in range(1, 9)}), 1.0)
    assert t.pwm_us == (1501, 1502, 1503, 1504, 1505, 1506)


def test_depth_from_vfr_hud_and_global_position() -> None:
    [d] = bound().decode(packet(lambda m: m.vfr_hud_encode(0, 0, 0, 0, -12.5, 0)), 1.0)
    assert d == Depth(1.0, 12.5)
    g = bound(depth_source="global_position")
    [d] = g.decode(packet(lambda m: m.global_position_int_encode(0, 0, 0, 0, -3456, 0, 0, 0, 0)),
                   1.0)
    assert d.depth_m == pytest.approx(3.456, abs=1e-12)
    assert g.decode(packet(lambda m: m.vfr_hud_encode(0, 0, 0, 0, -1.0, 0)), 1.0) == []


def test_depth_from_pressure_needs_a_surface_pressure() -> None:
    msg = packet(lambda m: m.scaled_pressure2_encode(0, 1115.75, 0, 2000))  # exact in float32
    d = bound(depth_source="pressure", rho_kg_m3=1000.0, g_m_s2=10.0)
    assert d.decode(msg, 1.0) == []
    assert d.rejected["SCALED_PRESSURE2"] == 1
    d.decode(packet(lambda m: m.param_value_encode(b"BARO2_GND_PRESS", 101480.0, 9, 900, 0)), 1)
    # (111575 − 101480) Pa / (1000 kg/m³ · 10 m/s²) = 1.0095 m
    assert d.decode(msg, 2.0)[0].depth_m == pytest.approx(1.0095, abs=1e-9)
    explicit = bound(depth_source="pressure", rho_kg_m3=1025.0, g_m_s2=9.81,
                     surface_pressure_Pa=101325.0)
    # (111575 − 101325) / (1025 · 9.81) = 10250 / 10055.25 = 1.019368…
    assert explicit.decode(msg, 2.0)[0].depth_m == pytest.approx(1.0193680, abs=1e-6)


def test_battery_from_sys_status_and_battery_status() -> None:
    d = bound()

    def sys_status(mv: int) -> Any:
        return packet(lambda m: m.sys_status_encode(0, 0, 0, 0, mv, -1, -1, 0, 0, 0, 0, 0, 0))

    assert d.decode(sys_status(16233), 1.0) == [Battery(1.0, 16.233)]
    assert d.decode(sys_status(65535), 1.0) == []
    cells = [3700, 3710, 3690, 3705] + [65535] * 6

    def status(ident: int) -> Any:
        return packet(lambda m: m.battery_status_encode(ident, 0, 0, 0, cells, 0, 0, 0, 0))

    [b] = d.decode(status(0), 2.0)
    assert b.voltage_V == pytest.approx(14.805, abs=1e-12)  # 3.700+3.710+3.690+3.705
    assert d.decode(status(1), 2.0) == []
    assert d.rejected == {"SYS_STATUS": 1}


def test_params_before_the_heartbeat_are_kept(bluerov: Profile) -> None:
    d = MavlinkDecoder.for_profile(bluerov)
    d.decode(packet(lambda m: m.param_value_encode(b"FRAME_CONFIG", 1, 9, 900, 0)), 0)
    d.decode(packet(lambda m: m.param_value_encode(b"MOT_1_DIRECTION", -1, 9, 900, 0)), 0)
    d.decode(packet(lambda m: m.param_value_encode(b"FRAME_CONFIG", 3, 9, 9, 0), compid=194), 0)
    d.decode(heartbeat(), 0.5)
    assert d.params.frame_config == 1 and d.params.motor_direction == {1: -1}
    problems = d.params.disagreements(bluerov)
    assert len(problems) == 2
    assert "FRAME_CONFIG is 1" in problems[0] and "MOT_1_DIRECTION = -1" in problems[1]


def test_vehicle_params_parse_names() -> None:
    p = VehicleParams()
    assert p.update("SERVO12_FUNCTION", 35) and p.update("MOT_10_DIRECTION", -1)
    assert not p.update("SERVOX_FUNCTION", 1) and not p.update("FRAME_CONFIG", math.nan)
    assert p.output_of(3) == 12 and p.output_of(4) == 4
    assert p.motor_direction == {10: -1} and p.motors() == (3,)
    assert motor_function(12) == 85
