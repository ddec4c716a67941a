"""The session recorder writes a tlog that pymavlink reads back, message for message."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
from pymavlink import mavutil

from tests.helpers import PROFILES
from trimd.core.events import Notice
from trimd.core.model import quaternion_from_euler
from trimd.core.profile import Profile
from trimd.core.samples import (
    Attitude,
    Battery,
    Depth,
    Health,
    HoldAttitude,
    PilotInput,
    Release,
    Thrusters,
    VehicleText,
)
from trimd.drivers.mavlink.decode import MavlinkDecoder
from trimd.logs.log import open_log
from trimd.logs.recorder import TlogRecorder, session_s, session_us
from trimd.logs.tlog import TlogReader


def record(path: Path, profile: Profile) -> list[object]:
    rec = TlogRecorder(path, profile, (PROFILES / "bluerov2-heavy.yaml").read_text())
    out = [
        rec.sample(Health(0.0, True, "ALT_HOLD", True)),
        rec.sample(Attitude(0.05, 0.1234567891, -0.2, 1.5, 0.01, 0.02, 0.03)),
        rec.sample(Thrusters(0.1, (1500.4, 1499.6, 1600, 1400, 1550, 1450, 1500, 1700))),
        rec.sample(Depth(0.2, 10.123456789)),
        rec.sample(Battery(0.3, 15.98765)),
    ]
    rec.command(0.4, HoldAttitude(math.radians(20), math.radians(20), 0.5))
    rec.notice(Notice(0.5, "warning", "a long warning text that does not fit in fifty "
                                      "bytes of one STATUSTEXT message — with ° signs"))
    rec.command(0.6, Release())
    rec.close()
    return out


def test_samples_come_back_as_recorded(tmp_path: Path, bluerov: Profile) -> None:
    path = tmp_path / "s.tlog"
    _health, att, thr, depth, batt = record(path, bluerov)
    assert isinstance(att, Attitude) and att.phi == float(np.float32(0.1234567891))
    assert isinstance(thr, Thrusters) and thr.pwm_us[:2] == (1500.0, 1500.0)
    assert isinstance(depth, Depth) and depth.depth_m == float(np.float32(10.123456789))
    assert isinstance(batt, Battery) and batt.voltage_V == 15.988
    mav = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    msgs = []
    while (m := mav.recv_match()) is not None:
        msgs.append(m)
    types = [m.get_type() for m in msgs]
    assert types[0] == "STATUSTEXT" and msgs[0].text == "trimd session start"
    assert "ENCAPSULATED_DATA" in types
    a = next(m for m in msgs if m.get_type() == "ATTITUDE")
    assert a.roll == att.phi and a.get_srcSystem() == 1
    s = next(m for m in msgs if m.get_type() == "SERVO_OUTPUT_RAW")
    assert [s.servo1_raw, s.servo3_raw, s.servo8_raw] == [1500, 1600, 1700]
    hb = next(m for m in msgs if m.get_type() == "HEARTBEAT")
    assert hb.custom_mode == 2 and hb.base_mode & 128 and hb.type == 12
    t = next(m for m in msgs if m.get_type() == "SET_ATTITUDE_TARGET")
    np.testing.assert_allclose(t.q, quaternion_from_euler(math.radians(20), math.radians(20),
                                                          0.5), atol=1e-7)
    assert t.type_mask & 64 and t.get_srcSystem() == 255
    texts = [m.text for m in msgs if m.get_type() == "STATUSTEXT"]
    assert "trimd: release control" in texts
    assert any(x.startswith("a long warning") for x in texts)


def test_vehicle_texts_replay_whole_and_trimd_texts_stay_trimd_s(tmp_path: Path,
                                                                  bluerov: Profile) -> None:
    path = tmp_path / "s.tlog"
    rec = TlogRecorder(path, bluerov, (PROFILES / "bluerov2-heavy.yaml").read_text())
    texts = ["Failsafe: pilot input lost, disarming", "PreArm: " + "0123456789" * 11,
             "y" * 100, "Mode change to GUIDED denied — 2 chunks with ° signs " * 2]
    rec.sample(Health(0.0, True, "ALT_HOLD", True))
    stored = [rec.sample(VehicleText(1.0 + k, 2 + k, text)) for k, text in enumerate(texts)]
    rec.sample(VehicleText(9.0, 42, "out-of-range severity"))
    rec.notice(Notice(10.0, "warning", "trimd's own warning"))
    rec.close()
    replayed = [s for s in TlogReader.open(path).samples(MavlinkDecoder.for_profile(bluerov))
                if isinstance(s, VehicleText)]
    assert replayed == [*stored, VehicleText(9.0, 7, "out-of-range severity")]
    assert [t.text for t in replayed[:4]] == texts


def test_someone_else_taking_over_is_recorded_and_replayed_as_the_pilot_input_it_was(
        tmp_path: Path, bluerov: Profile) -> None:
    path = tmp_path / "s.tlog"
    rec = TlogRecorder(path, bluerov, (PROFILES / "bluerov2-heavy.yaml").read_text())
    rec.sample(Health(0.0, True, "ALT_HOLD", True))
    source = "the vehicle reports control PILOT, mode MANUAL — a text of two chunks"
    stored = rec.sample(PilotInput(12.5, source))
    rec.close()
    assert stored == PilotInput(12.5, source)
    replayed = [s for s in open_log(path, bluerov).samples()
                if isinstance(s, PilotInput | VehicleText)]
    assert replayed == [stored]


def test_timestamps_are_session_time_from_the_first_record(tmp_path: Path,
                                                            bluerov: Profile) -> None:
    path = tmp_path / "s.tlog"
    record(path, bluerov)
    mav = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    stamps = []
    while (m := mav.recv_match()) is not None:
        stamps.append((m.get_type(), m._timestamp))
    t0 = stamps[0][1]
    att = next(t for kind, t in stamps if kind == "ATTITUDE")
    assert round(att - t0, 6) == 0.05


def test_mavlogdump_reads_a_recording(tmp_path: Path, bluerov: Profile) -> None:
    path = tmp_path / "s.tlog"
    record(path, bluerov)
    tool = Path(sys.executable).parent / "mavlogdump.py"
    proc = subprocess.run([sys.executable, str(tool), "--types", "ATTITUDE,SERVO_OUTPUT_RAW",
                           str(path)], capture_output=True, text=True, check=True, timeout=120)
    assert "ATTITUDE" in proc.stdout and "SERVO_OUTPUT_RAW" in proc.stdout


def test_quaternion_of_a_pure_yaw() -> None:
    np.testing.assert_allclose(quaternion_from_euler(0, 0, math.pi / 2),
                               [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-12)


def test_body_velocity_is_recorded_as_odometry(tmp_path: Path, bluerov: Profile) -> None:
    from trimd.core.samples import Velocity

    path = tmp_path / "v.tlog"
    rec = TlogRecorder(path, bluerov, "name: x\n")
    back = rec.sample(Velocity(1.0, 0.1, -0.2, 0.3))
    rec.close()
    mav = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    odo = None
    while (m := mav.recv_match()) is not None:
        if m.get_type() == "ODOMETRY":
            odo = m
    assert odo is not None and odo.child_frame_id == 12  # MAV_FRAME_BODY_FRD
    assert (odo.vx, odo.vy, odo.vz) == (back.u, back.v, back.w)  # type: ignore[union-attr]


def test_a_dive_longer_than_the_uint32_microsecond_clock_is_recorded(
        tmp_path: Path, bluerov: Profile) -> None:
    """SERVO_OUTPUT_RAW's time_usec wraps after 2³² µs (71.6 min; trimd serve records whole
    dives): the record is written, and its stamp still says the session time."""
    path = tmp_path / "long.tlog"
    rec = TlogRecorder(path, bluerov, (PROFILES / "bluerov2-heavy.yaml").read_text())
    rec.sample(Thrusters(5000.0, (1500.0,) * 8))
    rec.close()
    mav = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    stamps = []
    while (m := mav.recv_match()) is not None:
        stamps.append((m.get_type(), m._timestamp))
    servo = next(t for kind, t in stamps if kind == "SERVO_OUTPUT_RAW")
    assert round(servo - stamps[0][1], 6) == 5000.0


def test_a_millisecond_session_time_reads_back_bit_for_bit() -> None:
    """The live session rounds sample times to the millisecond and hands its procedure the
    time as the log stores it; the replay's session rounds the stored time to the
    millisecond again. Both must be the same float, or a cut at 15.0 s falls one sample
    apart (live 19.9 − 4.9 < 15 where the replay has 15.0): 2 h of milliseconds."""
    t = [k / 1000 for k in range(0, 7_200_000, 7)]
    stored = [session_s(session_us(x)) for x in t]
    assert stored == t
    assert [round(x * 1000.0) / 1000.0 for x in stored] == t
