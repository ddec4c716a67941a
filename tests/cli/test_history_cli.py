"""``trimd run`` stores its result in the trim history; ``trimd history`` lists and plots it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from trimd.app.history import History
from trimd.cli.main import main


def test_history_of_an_absent_or_empty_file_says_so(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "none.db"
    assert main(["history", "--db", str(path)]) == 0
    assert "no trim history yet" in capsys.readouterr().out
    assert not path.exists()  # reading creates nothing
    History(path).close()
    assert main(["history", "--db", str(path)]) == 0
    assert "is empty" in capsys.readouterr().out
    assert main(["history", "--db", str(path), "--vehicle", "rov"]) == 0
    assert "no records for vehicle rov" in capsys.readouterr().out
    assert main(["history", "--db", str(tmp_path / "absent.db"), "--json"]) == 0
    empty = json.loads(capsys.readouterr().out)
    assert empty["vehicles"] == [] and "no trim history yet" in empty["message"]


def test_history_defaults_to_the_data_dir(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["history"]) == 0  # conftest's TRIMD_DATA_DIR: a fresh folder
    assert "no trim history yet" in capsys.readouterr().out


def test_run_stores_its_trim_and_history_lists_and_plots_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "h.db"
    run = ["run", "--link", "sim:payload=0.4@W-front-stbd,seed=9", "--profile",
           "bluerov2-heavy", "--headless", "--yes", "--no-record", "--db", str(db)]
    assert main([*run, "--vehicle", "yellow"]) == 0
    assert main(run) == 0
    capsys.readouterr()
    assert main(["history", "--db", str(db), "--vehicle", "yellow", "--json"]) == 0
    [vehicle] = json.loads(capsys.readouterr().out)["vehicles"]
    assert vehicle["vehicle"] == "yellow"
    [trim] = vehicle["trims"]
    assert abs(trim["estimate"]["m_ext_kg"] - 0.4) < 0.1
    assert len(trim["estimate"]["cov_net"]) == 4
    assert trim["proposal"]["method"] == "milp" and trim["proposal"]["feasible"]
    assert main(["history", "--db", str(db)]) == 0
    out = capsys.readouterr().out
    assert "vehicle bluerov2-heavy" in out and "vehicle yellow" in out and "W − B +1.6" in out
    assert main(["history", "--db", str(db), "--plot", str(tmp_path / "p.png")]) == 2
    assert "--plot draws one vehicle" in capsys.readouterr().err
    png = tmp_path / "p.png"
    assert main(["history", "--db", str(db), "--vehicle", "yellow", "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_a_run_without_estimate_stores_nothing(tmp_path: Path) -> None:
    db = tmp_path / "h.db"
    code = main(["run", "--link", "udp:127.0.0.1:14550", "--profile", "bluerov2-heavy",
                 "--headless", "--yes", "--no-record", "--db", str(db)])
    assert code == 3 and not db.exists()


def test_history_shows_a_verify_hold_by_its_verdict(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "h.db"
    message = ("level: passive roll -0.18° ± 0.12°, pitch -0.19° ± 0.19° (predicted -0.24°, "
               "+0.09°); as predicted")
    with History(db) as h:
        h.record_verify("rov", 0.0, {"as_predicted": True, "message": message,
                                     "measured_N_Nm": [-41.6, 1.59, -1.5]})
    assert main(["history", "--db", str(db), "--vehicle", "rov"]) == 0
    out = capsys.readouterr().out
    assert f"1970-01-01 00:00:00 UTC  {message}\n" in out + "\n"
    assert "measured_N_Nm" not in out
