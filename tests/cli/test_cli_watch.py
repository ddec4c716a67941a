"""``trimd watch``: the real ArduSub logs end with a verdict, a live simulated dive gives
JSON lines, the plot is written, and usage mistakes are clear."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.helpers import ARDUSUB_LOGS
from trimd.cli.main import main

LOGS = ("mcqueen-small.tlog", "mcqueen-bad-crc.tlog", "mcqueen-small.BIN",
        "gat-00000029_filtered.BIN")
#: why each real log has no steady segment
WHY = {"mcqueen-small.tlog": "modes seen: MANUAL", "mcqueen-bad-crc.tlog": "modes seen: MANUAL",
       "mcqueen-small.BIN": "no thruster outputs",
       "gat-00000029_filtered.BIN": "transit (surge or sway effort)"}


@pytest.mark.parametrize("name", LOGS)
def test_real_logs_end_with_a_verdict(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["watch", str(ARDUSUB_LOGS / name), "--profile", "bluerov2-heavy"]) == 1
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err
    assert f"{name}: no steady segment: " in out.out and WHY[name] in out.out


def test_json_verdict_and_plot_of_a_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                        ) -> None:
    png = tmp_path / "watch.png"
    log = ARDUSUB_LOGS / "gat-00000029_filtered.BIN"
    assert main(["watch", str(log), "--profile", "bluerov2-heavy", "--json",
                 "--plot", str(png)]) == 1
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert last["type"] == "verdict" and last["segments"] == 0 and last["alerts"] == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_live_simulated_dive_gives_json_segments(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["watch", "--link", "sim:pilot=dive,seed=5", "--profile", "bluerov2-heavy",
                 "--json", "--duration", "300"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    segments = [x for x in lines if x["type"] == "segment"]
    assert len(segments) >= 2 and lines[-1]["type"] == "verdict"
    s = segments[0]
    assert s["net_moment_Nm"][2] is None and "not observable" in s["not_observable"]
    assert s["net_force_std_N"] > 0 and s["baseline"]


@pytest.mark.parametrize(("argv", "code", "words"), [
    (["watch", "--profile", "bluerov2-heavy"], 2, "either --link"),
    (["watch", "x.tlog", "--link", "sim", "--profile", "bluerov2-heavy"], 2, "either --link"),
    (["watch", "--link", "mavlink:udpin:127.0.0.1:14999?pilot=always", "--profile",
      "bluerov2-heavy"], 3, "sends no MANUAL_CONTROL"),
    (["watch", "--link", "mavlink:udpin:127.0.0.1:14999?ids=robot", "--profile",
      "bluerov2-heavy"], 3, "mavlink option ids='robot': expected one of gcs, vehicle"),
    (["watch", "no-such.tlog", "--profile", "bluerov2-heavy"], 2, "no such file"),
])
def test_usage_mistakes(argv: list[str], code: int, words: str,
                        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == code
    assert words in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("source", ["file", "history"])
def test_a_baseline_from_the_last_trim(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                       source: str) -> None:
    """``--baseline EST.json`` or ``--baseline last`` (the vehicle's last trim in the
    history; here an exact estimate of the simulated vehicle before it loses a piece) is
    the reference from the first segment; the segments and the alert are stored in the
    history, where ``trimd history`` lists them. Against an external baseline each
    segment's ± carries the baseline's too, so the alert takes the three segments after
    the drop (the hovers of the script, the turn between them breaking one in two)."""
    from tests.helpers import equilibrium_holds
    from trimd.app.history import History
    from trimd.core.estimate import estimate_static
    from trimd.core.estimate_json import estimate_to_dict
    from trimd.core.profile_yaml import load_profile
    from trimd.drivers.sim.payload import mass_properties

    profile = load_profile("bluerov2-heavy")
    m = mass_properties(profile)
    est = estimate_static(equilibrium_holds(profile, m.W, m.r_g), profile)
    db = str(tmp_path / "trimd.db")
    baseline = str(tmp_path / "last-trim.json")
    if source == "file":
        Path(baseline).write_text(json.dumps(estimate_to_dict(est)), encoding="utf-8")
    else:
        with History(db) as history:
            history.record_trim("bluerov2-heavy", "bluerov2-heavy", 0.0,
                                estimate_to_dict(est), None, None)
        baseline = "last"
    assert main(["watch", "--link", "sim:pilot=dive,seed=6,drop=lead-200g@W-aft-ctr@100",
                 "--profile", "bluerov2-heavy", "--json", "--duration", "420",
                 "--baseline", baseline, "--db", db]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    segments = [x for x in lines if x["type"] == "segment"]
    assert not any(s["baseline"] for s in segments)
    alerts = [x for x in lines if x["type"] == "alert"]
    assert alerts and alerts[0]["quantity"] == "net_force_N" and alerts[0]["total"] < 0
    assert alerts[0]["t_s"] > 100
    assert main(["history", "--db", db, "--json"]) == 0
    stored = json.loads(capsys.readouterr().out)["vehicles"][0]
    assert len(stored["watch_segments"]) == len(segments)
    assert len(stored["alerts"]) == len(alerts)


def test_post_dive_on_a_trimd_recording_with_short_holds(
        capsys: pytest.CaptureFixture[str]) -> None:
    """The golden recording (a trim of the simulated Sabertooth, whose stop rule ends each
    hold after ≈ 20 s): steady, armed in ALT_HOLD, but each stretch is shorter than a
    segment once settled and trimmed, and the verdict says so."""
    golden = Path(__file__).resolve().parent.parent / "data" / "golden"
    assert main(["watch", str(golden / "sabertooth-10kg-aftsb.tlog"), "--profile",
                 "sabertooth-dh2", "--json"]) == 1
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert last["type"] == "verdict" and last["segments"] == 0
    assert last["rejected"] == {"too short": 2} and "too short" in last["text"]
