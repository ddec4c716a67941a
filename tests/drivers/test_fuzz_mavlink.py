"""Fuzz the .tlog reader and the MAVLink decoder (issue 5: ≥ 10 000 examples each in CI).

Every test runs ``TRIMD_FUZZ_EXAMPLES`` examples (default 10 000, the CI figure; set it
lower while iterating). Each example is kept small (a few hundred bytes to a few KB) so
the whole file stays well under a minute.
"""

from __future__ import annotations

import math
import os
import struct
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.helpers import ARDUSUB_LOGS
from trimd.core.samples import Attitude, Battery, Depth, Health, Sample, Thrusters, VehicleText
from trimd.drivers.mavlink.decode import LIMITS, MavlinkDecoder
from trimd.logs.tlog import TlogReader

settings.register_profile(
    "trimd-fuzz", max_examples=int(os.environ.get("TRIMD_FUZZ_EXAMPLES", "3000")),
    deadline=None, suppress_health_check=[HealthCheck.too_slow])
FUZZ = settings.get_profile("trimd-fuzz")

REAL = (ARDUSUB_LOGS / "mcqueen-small.tlog").read_bytes()


def _real_records() -> list[tuple[bytes, str]]:
    """The first 400 good records of the real log (its bad-CRC frames left out)."""
    out = []
    for stamp, msg in TlogReader(REAL).messages():
        out.append((struct.pack(">Q", stamp) + bytes(msg.get_msgbuf()), msg.get_type()))
        if len(out) == 400:
            break
    return out


RECORDS, TYPES = (list(x) for x in zip(*_real_records(), strict=True))


def valid(s: Sample) -> bool:
    def ok(v: float, limit: str) -> bool:
        lo, hi = LIMITS[limit]
        return math.isfinite(v) and lo <= v <= hi

    if isinstance(s, Attitude):
        return (ok(s.phi, "roll_rad") and ok(s.theta, "pitch_rad") and ok(s.psi, "yaw_rad")
                and all(ok(w, "rate_rad_s") for w in (s.p, s.q, s.r)))
    if isinstance(s, Thrusters):
        return all(ok(p, "pwm_us") for p in s.pwm_us)
    if isinstance(s, Depth):
        return ok(s.depth_m, "depth_m")
    if isinstance(s, Battery):
        return ok(s.voltage_V, "voltage_V")
    if isinstance(s, VehicleText):
        return 0 <= s.severity <= 7 and isinstance(s.text, str)
    return isinstance(s, Health) and isinstance(s.mode, str) and math.isfinite(s.t_s)


def read_all(data: bytes) -> tuple[TlogReader, list[Sample]]:
    reader = TlogReader(data)
    samples = list(reader.samples(MavlinkDecoder((1, 2, 3, 4, 5, 6, 7, 8))))
    st_ = reader.stats
    assert st_.accounted_bytes == st_.size_bytes == len(data)
    assert all(valid(s) and math.isfinite(s.t_s) for s in samples)
    return reader, samples


@FUZZ
@given(st.binary(max_size=800))
def test_random_bytes_never_raise(data: bytes) -> None:
    read_all(data)


@pytest.mark.slow
@FUZZ
@given(st.integers(0, len(RECORDS) - 20), st.integers(1, 20), st.binary(max_size=24))
def test_mutated_real_log_never_raises(first: int, count: int, script: bytes) -> None:
    data = bytearray(b"".join(RECORDS[first:first + count]))
    edits = [script[i:i + 3] for i in range(0, len(script) - 2, 3)]
    for where_hi, where_lo, value in edits:  # set, insert or delete one byte
        i = (where_hi << 8 | where_lo) % (len(data) + 1)
        if value % 3 == 0:
            data.insert(i, value)
        elif i < len(data) and value % 3 == 1:
            del data[i]
        elif i < len(data):
            data[i] = value
    reader, _ = read_all(bytes(data))
    assert reader.stats.messages <= count + len(edits)  # no message is made up of nothing


@pytest.mark.slow
@FUZZ
@given(st.integers(0, len(RECORDS) - 12), st.integers(1, 12), st.binary(min_size=36,
                                                                         max_size=36))
def test_corrupted_frames_are_counted_exactly(first: int, count: int, script: bytes) -> None:
    """Flip one payload or CRC byte of some records: each is exactly one bad frame."""
    recs = [bytearray(r) for r in RECORDS[first:first + count]]
    hit = set()
    for k in range(count):
        pick, where, flip = script[3 * k:3 * k + 3]
        if pick & 1 and flip:
            header = 8 + (10 if recs[k][8] == 0xFD else 6)  # timestamp + MAVLink header
            recs[k][header + where % (len(recs[k]) - header)] ^= flip
            hit.add(k)
    reader = TlogReader(b"".join(recs))
    kept = [m.get_type() for _, m in reader.messages()]
    assert reader.stats.bad_crc == reader.stats.bad_frames == len(hit)
    assert kept == [TYPES[first + k] for k in range(count) if k not in hit]


_MAV = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)


def _message(kind: int, raw: bytes) -> Any:
    """One sample-bearing message whose fields are raw bit patterns (NaN, inf, huge …)."""
    f = struct.unpack("<6f", raw[:24])
    h = struct.unpack("<16H", raw[:32])
    if kind == 0:
        return _MAV.attitude_encode(0, *f)
    if kind == 1:
        return _MAV.servo_output_raw_encode(0, 0, *h)
    if kind == 2:
        return _MAV.vfr_hud_encode(0, 0, 0, 0, f[0], 0)
    if kind == 3:
        return _MAV.sys_status_encode(0, 0, 0, 0, h[0], -1, -1, 0, 0, 0, 0, 0, 0)
    return _MAV.battery_status_encode(0, 0, 0, 0, list(h[:10]), 0, 0, 0, 0)


@pytest.mark.slow
@FUZZ
@given(st.lists(st.tuples(st.integers(0, 4), st.binary(min_size=32, max_size=32)),
                min_size=1, max_size=4))
def test_decoder_never_yields_a_bad_sample(messages: list[tuple[int, bytes]]) -> None:
    decoder = MavlinkDecoder((1, 2, 3, 4, 5, 6, 7, 8))
    packets = [_MAV.heartbeat_encode(12, 3, 209, 2, 4)] + [_message(k, raw)
                                                           for k, raw in messages]
    stream = b"".join(struct.pack(">Q", 1_700_000_000_000_000 + i)
                      + bytes(m.pack(_MAV)) for i, m in enumerate(packets))
    reader = TlogReader(stream)
    samples = list(reader.samples(decoder))
    assert reader.stats.messages == len(packets)  # good frames carrying bad values
    assert all(valid(s) for s in samples)
    assert len(samples) - 1 + sum(decoder.rejected.values()) == len(messages)
