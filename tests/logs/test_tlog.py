"""The .tlog reader: real ArduSub logs against an independent pymavlink pass, and damage."""

from __future__ import annotations

import struct
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.helpers import ARDUSUB_LOGS
from trimd.core.errors import DataError
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Battery, Depth, Health, Thrusters
from trimd.drivers.mavlink.decode import MavlinkDecoder
from trimd.logs.tlog import TlogReader


def pymavlink_pass(path: Path) -> tuple[Counter[str], list[Any]]:
    """Message types and messages as pymavlink's own tlog reader sees them."""
    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    kinds: Counter[str] = Counter()
    messages = []
    while (msg := conn.recv_match()) is not None:
        kinds[msg.get_type()] += 1
        messages.append(msg)
    return kinds, messages


@pytest.mark.parametrize(("name", "bad"), [("mcqueen-bad-crc.tlog", 1967),
                                           ("mcqueen-small.tlog", 4)])
def test_real_logs_count_bad_frames_and_keep_every_good_message(name: str, bad: int) -> None:
    path = ARDUSUB_LOGS / name
    reader = TlogReader.open(path)
    ours = Counter(msg.get_type() for _, msg in reader.messages())
    theirs, _ = pymavlink_pass(path)
    assert theirs.pop("BAD_DATA") == bad
    assert reader.stats.bad_crc == bad and reader.stats.bad_frames == bad
    assert ours == theirs
    st = reader.stats
    assert st.resyncs == 0 and st.truncated_at is None
    assert st.accounted_bytes == st.size_bytes == path.stat().st_size
    assert st.gaps[(1, 1)] == 0  # the autopilot lost nothing


def test_real_bad_crc_frames_are_the_companion_distance_sensor() -> None:
    reader = TlogReader.open(ARDUSUB_LOGS / "mcqueen-bad-crc.tlog")
    good = sum(1 for _, m in reader.messages() if m.get_type() == "DISTANCE_SENSOR")
    assert good == 919
    # the lost DISTANCE_SENSOR frames show up as gaps in component 194's sequence
    assert 0 < reader.stats.gaps[(1, 194)] <= 1967


def test_small_tlog_decodes_into_every_kind_of_sample(bluerov: Profile) -> None:
    path = ARDUSUB_LOGS / "mcqueen-small.tlog"
    reader = TlogReader.open(path)
    samples = list(reader.samples(MavlinkDecoder.for_profile(bluerov)))
    by_kind: dict[type, list[Any]] = {}
    for s in samples:
        by_kind.setdefault(type(s), []).append(s)
    # independent expectation: vehicle (1/1) messages after its first HEARTBEAT
    _, messages = pymavlink_pass(path)
    seen_hb, expected = False, Counter[str]()
    pwm_dev = 0
    for m in messages:
        if m.get_type() == "BAD_DATA" or (m.get_srcSystem(), m.get_srcComponent()) != (1, 1):
            continue
        seen_hb = seen_hb or m.get_type() == "HEARTBEAT"
        if seen_hb:
            expected[m.get_type()] += 1
            if m.get_type() == "SERVO_OUTPUT_RAW":
                pwm_dev = max(pwm_dev, *(abs(getattr(m, f"servo{k}_raw") - 1500)
                                         for k in range(1, 9)))
    assert len(by_kind[Attitude]) == expected["ATTITUDE"] > 5000
    assert len(by_kind[Thrusters]) == expected["SERVO_OUTPUT_RAW"]
    assert len(by_kind[Depth]) == expected["VFR_HUD"]
    assert len(by_kind[Battery]) == expected["SYS_STATUS"] + expected["BATTERY_STATUS"]
    assert len(by_kind[Health]) == expected["HEARTBEAT"]
    assert max(abs(p - 1500) for t in by_kind[Thrusters] for p in t.pwm_us) == pwm_dev == 223
    assert {h.mode for h in by_kind[Health]} == {"MANUAL"}
    assert sum(h.armed for h in by_kind[Health]) == 16  # armed ~16 s at 1 Hz
    assert all(15.0 < b.voltage_V < 17.5 for b in by_kind[Battery])
    assert all(abs(d.depth_m) < 0.5 for d in by_kind[Depth])  # on the bench
    t = [s.t_s for s in samples]
    assert t[0] >= 0 and t[-1] == pytest.approx(263.4, abs=0.1)


# ---------------------------------------------------------------- synthetic damage
def records(n: int, *, v1_every: int = 0, t0_us: int = 1_700_000_000_000_000) -> list[bytes]:
    """``n`` ATTITUDE records 0.1 s apart (every ``v1_every``-th one in MAVLink 1)."""
    out = []
    for i in range(n):
        mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        mav.seq = i % 256
        v1 = bool(v1_every) and i % v1_every == 0
        msg = mav.attitude_encode(i, 0.01 * i, 0, 0, 0, 0, 0)
        out.append(struct.pack(">Q", t0_us + 100_000 * i)
                   + bytes(msg.pack(mav, force_mavlink1=v1)))
    return out


def test_mavlink1_and_mavlink2_frames_both_decode() -> None:
    recs = records(10, v1_every=3)
    assert {r[8] for r in recs} == {0xFD, 0xFE}
    reader = TlogReader(b"".join(recs))
    rolls = [m.roll for _, m in reader.messages()]
    assert rolls == pytest.approx([0.01 * i for i in range(10)])
    assert reader.stats.bad_frames == 0 and sum(reader.stats.gaps.values()) == 0


def test_truncated_final_record_is_reported_not_fatal() -> None:
    recs = records(5)
    data = b"".join(recs)[:-3]
    reader = TlogReader(data)
    assert len(list(reader.messages())) == 4
    assert reader.stats.truncated_at == sum(map(len, recs[:4]))
    assert reader.stats.bad_frames == 0 and reader.stats.accounted_bytes == len(data)


def test_a_damaged_stretch_is_skipped_and_reading_resumes() -> None:
    recs = records(8)
    garbage = b"\x00\xfd\x12garbage\xfe"
    data = b"".join(recs[:3]) + garbage + b"".join(recs[3:])
    reader = TlogReader(data)
    assert len(list(reader.messages())) == 8
    assert reader.stats.resyncs == 1 and reader.stats.skipped_bytes == len(garbage)
    assert reader.stats.accounted_bytes == len(data)
    assert reader.stats.first_bad_at == sum(map(len, recs[:3]))


def test_bad_crc_frame_is_counted_and_its_neighbours_kept() -> None:
    recs = records(6)
    broken = bytearray(recs[2])
    broken[-1] ^= 0x55
    reader = TlogReader(b"".join([*recs[:2], bytes(broken), *recs[3:]]))
    assert [m.time_boot_ms for _, m in reader.messages()] == [0, 1, 3, 4, 5]
    assert reader.stats.bad_crc == 1 and reader.stats.gaps[(1, 1)] == 1
    assert reader.stats.first_bad_at == sum(map(len, recs[:2]))


def test_time_jump_is_damage() -> None:
    recs = records(4)
    bad_time = struct.pack(">Q", 1) + recs[2][8:]
    reader = TlogReader(b"".join([recs[0], recs[1], bad_time, recs[3]]))
    assert [m.time_boot_ms for _, m in reader.messages()] == [0, 1, 3]
    assert reader.stats.resyncs == 1 and reader.stats.skipped_bytes == len(bad_time)


def test_empty_and_missing_files(tmp_path: Path) -> None:
    empty = tmp_path / "empty.tlog"
    empty.write_bytes(b"")
    reader = TlogReader.open(empty)
    assert list(reader.messages()) == [] and reader.stats.truncated_at is None
    with pytest.raises(DataError, match="cannot read"):
        TlogReader.open(tmp_path / "missing.tlog")


def test_unknown_message_ids_are_counted_not_trusted() -> None:
    recs = records(3)
    header = bytes([0xFD, 4, 0, 0, 7, 1, 1]) + (60000).to_bytes(3, "little")
    unknown = recs[0][:8] + header + b"\x01\x02\x03\x04" + b"\x00\x00"  # no CRC can be checked
    reader = TlogReader(b"".join([recs[0], unknown, recs[1], recs[2]]))
    assert len(list(reader.messages())) == 3
    assert reader.stats.unknown == 1 and reader.stats.bad_frames == 0
    assert reader.stats.accounted_bytes == reader.stats.size_bytes
