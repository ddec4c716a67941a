"""``trimd float --correct`` and ``trimd calibrate``: input that cannot be used ends with
exit 2 and a message that says what is wrong and what to give, before any link opens (so
nothing is commanded and no session log is written)."""

from __future__ import annotations

from pathlib import Path

import pytest

from trimd.cli.main import main


def test_float_correct_with_a_missing_trim_file_commands_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "float.tlog"
    code = main(["float", "--link", "sim:", "--profile", "bluerov2-heavy", "--yes",
                 "--record", str(log), "--correct", str(tmp_path / "nope.json")])
    err = capsys.readouterr().err
    assert code == 2 and "nope.json" in err, err
    assert "Traceback" not in err and not log.exists()


def test_float_correct_without_a_trim_in_the_history_says_to_give_one(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "float.tlog"
    code = main(["float", "--link", "sim:", "--profile", "bluerov2-heavy", "--yes",
                 "--record", str(log), "--db", str(tmp_path / "trimd.db"), "--vehicle",
                 "rov", "--correct"])
    err = capsys.readouterr().err
    assert code == 2 and "no trim with a proposal for vehicle rov" in err, err
    assert "give the trim (TRIM.json)" in err and not log.exists()


def test_float_correct_alone_without_the_history_says_to_give_the_trim(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "float.tlog"
    code = main(["float", "--link", "sim:", "--profile", "bluerov2-heavy", "--yes",
                 "--record", str(log), "--no-history", "--correct"])
    err = capsys.readouterr().err
    assert code == 2 and "without the trim history, give the trim (TRIM.json)" in err, err
    assert not log.exists()


@pytest.mark.parametrize(("args", "said"), [
    ([], "--link, --mass (or --band) required (or --replay HOLD1 HOLD2 …)"),
    (["--link", "sim:"], "--mass (or --band) required (or --replay HOLD1 HOLD2 …)"),
    (["--link", "sim:", "--mass", "0.5"], "expected KG@SLOT (or KG@SLOT+KG@SLOT"),
    (["--link", "sim:", "--mass", "0.5@W-mid-ctr+"], "expected KG@SLOT (or KG@SLOT+"),
    (["--link", "sim:", "--mass", "0.5@W-mid-ctr", "--band"],
     "--band chooses the load itself: give --band or --mass, not both"),
    (["--link", "sim:", "--mass", "0.5@W-front-stbd", "--hold-s", "5"],
     "--hold-s 5: a level hold collects for at least 10 s"),
    (["--replay", "a.tlog", "b.tlog", "--hold-s", "60"],
     "--hold-s is the live calibration's: a replay collects each hold as long as its "
     "recording says"),
])
def test_calibrate_says_what_it_needs(args: list[str], said: str, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["calibrate", "--profile", "bluerov2-heavy", "--yes", "--no-record",
                 "--db", str(tmp_path / "trimd.db"), *args])
    err = capsys.readouterr().err
    assert code == 2 and said in err and "Traceback" not in err, err


@pytest.mark.parametrize(("profile", "mass", "advised"), [
    ("sabertooth-dh2", "4.55@FrontSB", True), ("sabertooth-dh2", "-18.2@AftP", False),
    ("bluerov2-heavy", "0.546@W-front-stbd", False)])
def test_calibrate_advises_a_heavier_weight_when_it_would_learn_little(
        profile: str, mass: str, advised: bool, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The note comes before anything is asked or commanded (here: headless without
    --yes, which stops there)."""
    code = main(["calibrate", "--profile", profile, "--link", "sim:", "--mass", mass,
                 "--no-record", "--db", str(tmp_path / "trimd.db")])
    err = capsys.readouterr().err
    assert code == 2 and "pass --yes" in err, err
    note = ("note: the heaviest weight, 4.55 kg in water, is 0.38 % of the vehicle's 1184 kg"
            in err and "a weight of 11.8 kg or more (1 %) teaches more" in err)
    assert note == advised and ("note:" in err) == advised, err
