"""The DataFlash reader on both real ArduSub .BIN logs, checked against DFReader itself."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
from pymavlink import DFReader

from tests.helpers import ARDUSUB_LOGS
from trimd.core.errors import DataError
from trimd.core.samples import Attitude, Battery, Depth, Health, ModeClass, Thrusters
from trimd.logs.dataflash import DataflashReader

SMALL = ARDUSUB_LOGS / "mcqueen-small.BIN"
GAT = ARDUSUB_LOGS / "gat-00000029_filtered.BIN"


def raw(path: Path, kind: str) -> list[Any]:
    log = DFReader.DFReader_binary(str(path), zero_time_base=False)
    out = []
    while (m := log.recv_msg()) is not None:
        if m.get_type() == kind:
            out.append(m)
    return out


def kinds(samples: list[Any], kind: type) -> list[Any]:
    return [s for s in samples if isinstance(s, kind)]


def test_small_bin_is_a_six_thruster_bench_log() -> None:
    reader = DataflashReader(SMALL)
    samples = list(reader.samples())
    assert reader.firmware is not None and reader.firmware.startswith("ArduSub V4.1.0")
    assert reader.params.frame_config == 1
    assert reader.params.motors() == (1, 2, 3, 4, 5, 6)
    assert reader.params.motor_direction[1] == -1 and reader.params.motor_direction[3] == 1
    thrusters = kinds(samples, Thrusters)
    assert len(thrusters) == reader.counts["RCOU"] == 237
    pwm = [p for t in thrusters for p in t.pwm_us]
    assert len(thrusters[0].pwm_us) == 6 and (min(pwm), max(pwm)) == (1492, 1508)
    att = kinds(samples, Attitude)
    assert len(att) == 237 - 1  # the first ATT precedes the first RATE: its rates are unknown
    assert reader.rejected == {"ATT": 1}
    health = kinds(samples, Health)
    assert [(h.mode, h.armed) for h in health][-1] == ("MANUAL", False)  # the ARM 0 record
    assert health[-1].mode_class is ModeClass.MANUAL
    assert reader.armed_known


def test_att_degrees_become_radians_and_yaw_is_wrapped() -> None:
    reader = DataflashReader(SMALL)
    att = kinds(list(reader.samples()), Attitude)
    records = raw(SMALL, "ATT")[1:]
    rates = raw(SMALL, "RATE")
    assert len(att) == len(records)
    first, rec = att[0], records[0]
    assert first.phi == pytest.approx(math.radians(rec.Roll), abs=1e-12)
    assert first.theta == pytest.approx(math.radians(rec.Pitch), abs=1e-12)
    assert rec.Yaw > 180 and first.psi == pytest.approx(math.radians(rec.Yaw - 360), abs=1e-12)
    assert first.p == pytest.approx(math.radians(rates[0].R), abs=1e-12)


def test_gat_bin_without_unit_records_is_a_live_dive() -> None:
    reader = DataflashReader(GAT)
    samples = list(reader.samples())
    assert reader.counts["UNIT"] == reader.counts["MULT"] == 0
    assert reader.firmware is None and reader.params.frame_config is None
    assert not reader.armed_known and reader.error is None
    health = kinds(samples, Health)
    modes = [h.mode for h in health]
    assert modes == ["SURFTRAK", "GUIDED", "ALT_HOLD", "GUIDED", "STABILIZE", "GUIDED"]
    # ArduSub's classes; the log does not say whether the vehicle was armed
    assert [h.mode_class for h in health][1:5] == [
        ModeClass.AUTONOMOUS, ModeClass.DEPTH_HOLDING, ModeClass.AUTONOMOUS,
        ModeClass.STABILISED]
    assert {h.armed for h in health} == {None}
    depth = [d.depth_m for d in kinds(samples, Depth)]
    assert min(depth) > 12.4 and max(depth) < 13.8
    ctun = raw(GAT, "CTUN")
    assert depth[0] == -ctun[0].Alt and len(depth) == len(ctun)
    att = kinds(samples, Attitude)
    assert max(abs(math.degrees(a.phi)) for a in att) < 2.9
    assert len(kinds(samples, Thrusters)) == 1999
    assert all(1.0 < b.voltage_V < 20.0 for b in kinds(samples, Battery))
    assert reader.first_us is not None and reader.last_us is not None
    assert (reader.last_us - reader.first_us) * 1e-6 == pytest.approx(200.0, abs=0.1)
    assert samples[-1].t_s > 199.8


def test_baro_depth_source() -> None:
    reader = DataflashReader(GAT, depth_source="baro", baro_instance=1)
    depth = kinds(list(reader.samples()), Depth)
    expected = [-m.Alt for m in raw(GAT, "BARO") if m.I == 1]
    assert [d.depth_m for d in depth] == expected


def test_not_a_log(tmp_path: Path) -> None:
    bad = tmp_path / "x.BIN"
    bad.write_bytes(b"\x00" * 10)
    reader = DataflashReader(bad)
    assert list(reader.samples()) == [] and not reader.counts
    with pytest.raises(DataError, match="cannot read"):
        DataflashReader(tmp_path / "missing.BIN")


def test_damage_is_counted_quietly_and_reading_goes_on(
        tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    """A cut-off log and one with 3000 zeroed bytes: the reader says where, keeps every
    record it can, and pymavlink's per-byte complaints never reach the terminal."""
    data = GAT.read_bytes()
    whole = sum(1 for _ in DataflashReader(GAT).samples())
    cut, zeroed = tmp_path / "cut.BIN", tmp_path / "zeroed.BIN"
    cut.write_bytes(data[:150_001])
    zeroed.write_bytes(data[:50_000] + bytes(3000) + data[53_000:])
    capfd.readouterr()

    reader = DataflashReader(cut)
    n_cut = sum(1 for _ in reader.samples())
    assert reader.truncated_at is not None and 150_001 - reader.truncated_at < 200
    assert 0 < n_cut < whole and reader.skipped_bytes == 0

    reader = DataflashReader(zeroed)
    n_zeroed = sum(1 for _ in reader.samples())
    assert 3000 <= reader.skipped_bytes < 3200 and 49_800 < (reader.first_skip_at or 0) <= 50_100
    assert whole - 20 < n_zeroed < whole and reader.truncated_at is None
    out, err = capfd.readouterr()
    assert "bad header" not in err + out and "Skipped" not in err + out
