"""``trimd inspect`` on the real ArduSub logs, a synthetic hold, and unreadable files."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.helpers import ARDUSUB_LOGS
from trimd.app.log_report import NO_PROFILE, inspect_log
from trimd.cli.main import main
from trimd.core.profile_yaml import load_profile

ARMED, DISARMED, ALT_HOLD, MANUAL = 128 | 81, 81, 2, 19


@pytest.mark.slow
@pytest.mark.parametrize("name", ["mcqueen-small.tlog", "mcqueen-bad-crc.tlog",
                                  "mcqueen-small.BIN", "gat-00000029_filtered.BIN"])
def test_real_logs_end_with_a_clear_statement(name: str, capsys: pytest.CaptureFixture[str]
                                              ) -> None:
    assert main(["inspect", str(ARDUSUB_LOGS / name)]) == 0
    out = capsys.readouterr().out
    assert "Traceback" not in out
    assert out.rstrip().endswith(f"No steady attitude holds in this log: {NO_PROFILE}.")
    assert "ATT" in out and "modes:" in out
    # with a profile the holds are looked for, and the report says why there are none
    assert main(["inspect", str(ARDUSUB_LOGS / name), "--profile", "bluerov2-heavy"]) == 0
    last = capsys.readouterr().out.rstrip().splitlines()[-1]
    if name == "gat-00000029_filtered.BIN":   # a level hover in SURFTRAK, 35.3–69.7 s
        assert last == "1 steady attitude hold(s) found.", last
        return
    assert last.startswith("No steady attitude holds in this log: ") and NO_PROFILE not in last
    assert any(why in last for why in ("never armed", "no attitude plateau settled",
                                       "no outputs of the profile's thrusters")), last


def test_bad_crc_log_report(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["inspect", str(ARDUSUB_LOGS / "mcqueen-bad-crc.tlog"), "--json",
                 "--profile", "trimd/profiles/bluerov2-heavy.yaml"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["format"] == "MAVLink tlog" and r["bad_frames"] == 1967
    assert r["firmware"].startswith("ArduSub V4.1.0") and r["frame_config"] == 2
    assert r["duration_s"] == pytest.approx(316.4, abs=0.1)
    assert r["streams"]["ATTITUDE"]["rate_hz"] == pytest.approx(19.6, abs=0.1)
    assert [m["mode"] for m in r["modes"]] == ["MANUAL"] and r["armed_periods"] == []
    # the vehicle reverses motors 1, 2, 5, 8 (MOT_n_DIRECTION = -1); the profile does not
    assert len(r["profile_disagreements"]) == 4
    assert r["holds"] == [] and "never armed" in r["no_holds_because"]
    assert "modes seen: MANUAL" in r["no_holds_because"]


def test_gat_report_modes_and_unknown_arming() -> None:
    r = inspect_log(ARDUSUB_LOGS / "gat-00000029_filtered.BIN")
    assert [m["mode"] for m in r["modes"]] == ["SURFTRAK", "GUIDED", "ALT_HOLD", "GUIDED",
                                              "STABILIZE", "GUIDED"]
    assert r["armed_periods"] is None  # not logged
    assert 12.4 < r["depth_m"][0] < r["depth_m"][1] < 13.8
    assert r["samples"]["Attitude"] == 1998
    assert r["holds"] is None and r["no_holds_because"] == NO_PROFILE


@pytest.mark.parametrize(("name", "expected"), [
    ("mcqueen-small.tlog", ["ArduSub V4.1.1 BETA5 (66c674c1)", "Frame: VECTORED_6DOF"]),
    ("mcqueen-small.BIN", ["ArduSub V4.1.0 (89639005)", "EKF3 IMU0 forced reset"]),
    ("gat-00000029_filtered.BIN", ["rangefinder target is 2.06 meters"])])
def test_the_vehicle_s_messages_are_reported(name: str, expected: list[str],
                                             capsys: pytest.CaptureFixture[str]) -> None:
    r = inspect_log(ARDUSUB_LOGS / name)
    texts = [m["text"] for m in r["vehicle_messages"]]
    assert all(e in texts for e in expected), texts
    assert main(["inspect", str(ARDUSUB_LOGS / name)]) == 0
    out = capsys.readouterr().out
    assert f"vehicle messages: {len(texts)}" in out and f"info: {expected[-1]}" in out


def synthetic_hold(path: Path, base_mode: int, mode: int, seconds: float = 40.0) -> None:
    """A vehicle holding roll 5°, pitch −3° at 10 Hz with a little sensor noise, its
    thrusters at neutral (5 Hz)."""
    rng = np.random.default_rng(1)
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    t0 = 1_700_000_000_000_000
    with open(path, "wb") as f:
        for i in range(int(seconds * 10)):
            t_us = t0 + i * 100_000
            if i % 10 == 0:
                hb = mav.heartbeat_encode(12, 3, base_mode, mode, 4)
                f.write(struct.pack(">Q", t_us) + bytes(hb.pack(mav)))
            if i % 2 == 0:
                servo = mav.servo_output_raw_encode(i * 100_000, 0, *[1500] * 8)
                f.write(struct.pack(">Q", t_us + 5) + bytes(servo.pack(mav)))
            n = 1e-4 * rng.standard_normal(5)
            att = mav.attitude_encode(i * 100, np.radians(5) + n[0], np.radians(-3) + n[1], 1.0,
                                      n[2], n[3], n[4])
            f.write(struct.pack(">Q", t_us + 10) + bytes(att.pack(mav)))


def test_a_steady_armed_hold_is_found(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                      ) -> None:
    log = tmp_path / "hold.tlog"
    synthetic_hold(log, ARMED, ALT_HOLD)
    assert main(["inspect", str(log), "--profile", "bluerov2-heavy"]) == 0
    out = capsys.readouterr().out
    assert "hold 1: roll 5.00°, pitch -3.00°" in out
    assert out.rstrip().endswith("1 steady attitude hold(s) found.")
    [hold] = inspect_log(log, load_profile("bluerov2-heavy"))["holds"]
    assert hold["roll_deg"] == pytest.approx(5.0, abs=0.01)
    assert hold["pitch_deg"] == pytest.approx(-3.0, abs=0.01)
    [(start, end)] = hold["plateaus_s"]
    assert end - start > 20 and hold["samples"] > 200


def test_steady_but_disarmed_is_not_a_hold(tmp_path: Path) -> None:
    log = tmp_path / "bench.tlog"
    synthetic_hold(log, DISARMED, MANUAL)
    r = inspect_log(log, load_profile("bluerov2-heavy"))
    assert r["holds"] == [] and r["no_holds_because"].startswith("never armed")


@pytest.mark.parametrize("content", [b"", b"\x00" * 100, bytes(range(256)) * 4])
def test_unreadable_logs_are_a_data_error(tmp_path: Path, content: bytes,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("junk.tlog", "junk.BIN"):
        log = tmp_path / name
        log.write_bytes(content)
        assert main(["inspect", str(log)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("trimd: error:") and str(log) in err
    assert main(["inspect", str(tmp_path / "missing.tlog")]) == 2
