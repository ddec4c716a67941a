"""Replay: a recorded session reproduces its live result exactly; foreign and damaged logs
end with a clear statement, never a traceback."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.helpers import ARDUSUB_LOGS, PROFILES, REPO
from trimd.cli.main import main
from trimd.logs.replay import recorded_profile_yaml

LIVE = ["run", "--link", "sim:payload=0.4@W-aft-port,seed=4", "--profile", "bluerov2-heavy",
        "--headless", "--yes", "--json"]


def last_json(text: str) -> dict[str, object]:
    result: dict[str, object] = json.loads(text.strip().splitlines()[-1])
    return result


def test_replay_reproduces_the_live_result_exactly(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "live.tlog"
    assert main([*LIVE, "--record", str(log)]) == 0
    live = last_json(capsys.readouterr().out)
    assert recorded_profile_yaml(log) == (PROFILES / "bluerov2-heavy.yaml").read_text()
    assert main(["replay", str(log), "--json"]) == 0  # no --profile: the log carries it
    replayed = last_json(capsys.readouterr().out)
    assert live["type"] == replayed["type"] == "result"
    assert replayed["estimate"] == live["estimate"]
    assert replayed["proposal"] == live["proposal"]
    # a damaged profile block (one bad frame in it): --profile stands in for it
    data = bytearray(log.read_bytes())
    block = data.index(b"\xff\xbe\x83\x00\x00")  # trimd's first ENCAPSULATED_DATA
    data[block + 20] ^= 0xFF
    damaged = tmp_path / "damaged.tlog"
    damaged.write_bytes(bytes(data))
    assert main(["replay", str(damaged), "--json"]) == 2
    assert "pass --profile" in capsys.readouterr().err
    assert main(["replay", str(damaged), "--json", "--profile", "bluerov2-heavy"]) == 0
    out, err = capsys.readouterr()
    assert "replaying with --profile bluerov2-heavy" in err
    assert last_json(out)["estimate"] == live["estimate"]


def test_replay_link_in_trimd_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "live.tlog"
    assert main([*LIVE, "--record", str(log)]) == 0
    live = last_json(capsys.readouterr().out)
    assert main(["run", "--link", f"replay:{log}", "--profile", "bluerov2-heavy",
                 "--headless", "--yes", "--json", "--no-record"]) == 0
    assert last_json(capsys.readouterr().out)["estimate"] == live["estimate"]


@pytest.mark.parametrize("name", ["mcqueen-small.tlog", "mcqueen-bad-crc.tlog",
                                  "mcqueen-small.BIN"])
def test_real_logs_without_holds_end_clearly(name: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(ARDUSUB_LOGS / name), "--profile", "bluerov2-heavy"]) == 1
    out = capsys.readouterr().out
    assert "No steady attitude holds" in out and " s (starts at" in out  # duration


def test_a_live_dive_with_one_level_hover_ends_clearly(capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    """The Seattle pier dive hovers level in SURFTRAK for 35 s: one steady hold (its effort
    only wanders), level, so z_g cannot be estimated, and the replay says so."""
    assert main(["replay", str(ARDUSUB_LOGS / "gat-00000029_filtered.BIN"), "--profile",
                 "bluerov2-heavy"]) == 1
    captured = capsys.readouterr()
    assert "1 steady attitude hold(s) found." in captured.out
    assert "every hold was level" in captured.err and "Traceback" not in captured.err


def test_foreign_log_needs_a_profile(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(ARDUSUB_LOGS / "mcqueen-small.tlog")]) == 2
    assert "pass --profile" in capsys.readouterr().err


def test_truncated_recording_replays_up_to_the_damage(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "live.tlog"
    assert main([*LIVE, "--record", str(log)]) == 0
    capsys.readouterr()
    data = log.read_bytes()
    cut = tmp_path / "cut.tlog"
    cut.write_bytes(data[: len(data) // 2 + 5])
    assert main(["replay", str(cut), "--json"]) == 1
    err = capsys.readouterr().err
    assert "truncated record at byte" in err and "Traceback" not in err
    # damage in the middle: skipped, named by its byte offset, the rest replayed
    middle = len(data) // 2
    damaged = tmp_path / "damaged.tlog"
    damaged.write_bytes(data[:middle] + bytes(5000) + data[middle + 5000:])
    main(["replay", str(damaged), "--json"])
    err = capsys.readouterr().err
    assert re.search(r"1 bad frames skipped \(the first at byte \d+\)", err), err
    assert "Traceback" not in err


@pytest.mark.slow
def test_kill_9_leaves_a_log_that_replays(tmp_path: Path) -> None:
    """The daemon is killed mid-procedure; at most a second is lost and the file replays."""
    log = tmp_path / "killed.tlog"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "trimd", "run", "--link",
                             "sim:payload=10@AftSB", "--profile", "sabertooth-dh2", "--headless",
                             "--yes", "--record", str(log)], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:  # wait until the first hold is commanded, then kill
        if "command: hold" in line:
            break
    # the hold's notice is on disk once the file has grown past it by more than the
    # writer's buffer (a fixed sleep here failed on a loaded machine); a whole trim takes
    # ~1 s of wall time and writes ~300 kB: kill well inside it
    grown = log.stat().st_size + 32_000
    while log.stat().st_size < grown and proc.poll() is None:
        time.sleep(0.002)
    assert proc.poll() is None, "the trim ended before it could be killed"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert log.stat().st_size > 1000
    replay = subprocess.run([sys.executable, "-m", "trimd", "replay", str(log)], cwd=REPO,
                            capture_output=True, text=True, timeout=300, check=False)
    assert replay.returncode == 1  # the recording ends before a result
    assert "Traceback" not in replay.stderr
    assert "hold 1/2" in replay.stdout  # it replayed into the procedure


def test_sigterm_releases_and_closes_the_log(tmp_path: Path) -> None:
    log = tmp_path / "term.tlog"
    proc = subprocess.Popen([sys.executable, "-m", "trimd", "run", "--link",
                             "sim:payload=10@AftSB", "--profile", "sabertooth-dh2", "--headless",
                             "--yes", "--record", str(log)], cwd=REPO,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        if "command: hold" in line:
            break
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert "command: release control" in out and "stopped by SIGTERM" in out + err
    texts = subprocess.run([sys.executable, str(Path(sys.executable).parent / "mavlogdump.py"),
                            "--types", "STATUSTEXT", str(log)], capture_output=True, text=True,
                           timeout=120, check=True).stdout
    assert "trimd: release control" in texts


def test_replay_of_a_verify_hold_reproduces_its_verdict(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A verify hold's recording carries its verify target: replayed, it is one level hold
    again (not a trim) and gives the live verdict exactly; a damaged target is a clear
    error (exit 2)."""
    from tests.helpers import carried
    from trimd.ballast.check import SlotLoad
    from trimd.core.profile_yaml import load_profile
    from trimd.logs.replay import recorded_verify_target

    common = ["--profile", "sabertooth-dh2", "--headless", "--yes", "--json", "--no-history"]
    assert main(["run", "--link", "sim:payload=10@AftSB", *common, "--no-record"]) == 0
    trim = tmp_path / "trim.json"
    trim.write_text(capsys.readouterr().out)
    slots = tuple(SlotLoad(s["name"], tuple(s["position_m"]), 0, 0, 0, 0, s["net_down_N"])
                  for s in last_json(trim.read_text())["proposal"]["slots"])  # type: ignore[index]
    log = tmp_path / "verify.tlog"
    g = load_profile("sabertooth-dh2").gravity_m_s2
    link = f"sim:payload=10@AftSB+{carried(slots, g)},seed=3"  # the ballast fitted
    assert main(["run", "--link", link, *common, "--verify", str(trim), "--record",
                 str(log)]) == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    live = [x for x in lines if x["type"] == "verification"]
    assert len(live) == 1 and live[0]["as_predicted"], live
    assert recorded_verify_target(log) is not None
    assert recorded_profile_yaml(log) == (PROFILES / "sabertooth-dh2.yaml").read_text()

    assert main(["replay", str(log), "--json"]) == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    replayed = [x for x in lines if x["type"] == "verification"]
    assert replayed == live  # the measurement, the comparison and the verdict, exactly
    commands = [x["command"] for x in lines if x["type"] == "command"]
    assert len(commands) == 2 and commands[0].startswith("hold roll 0")  # one hold, release

    data = bytearray(log.read_bytes())
    header = data.index(b"trimd verify target")
    block = data.index(b"\xff\xbe\x83\x00\x00", header)  # the target's first data packet
    data[block + 20] ^= 0xFF
    damaged = tmp_path / "damaged.tlog"
    damaged.write_bytes(bytes(data))
    assert main(["replay", str(damaged), "--json"]) == 2
    assert "verify target is damaged" in capsys.readouterr().err


def test_an_old_verify_recording_says_what_it_is(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A verify hold recorded before recordings carried their verify target replays as a
    trim, which fails (one hold); the replay then says what the recording is."""
    import asyncio

    from tests.helpers import carried, sim_trim
    from trimd.app.connect import open_link
    from trimd.app.session import Session
    from trimd.ballast.propose import Proposal
    from trimd.ballast.verify import verify_hold
    from trimd.core.procedure import Procedure
    from trimd.core.profile_yaml import load_profile, read_profile_text
    from trimd.logs.recorder import TlogRecorder

    profile = load_profile(PROFILES / "sabertooth-dh2.yaml")   # the fixture's: a shared trim
    trim = sim_trim(profile, "10@AftSB", 0)
    estimate, proposal = trim.result.estimate, trim.result.proposal
    assert estimate is not None and isinstance(proposal, Proposal)
    log = tmp_path / "old-verify.tlog"

    async def old_verify() -> None:
        extra = carried(proposal.slots, profile.gravity_m_s2)
        link = await open_link(f"sim:payload=10@AftSB+{extra}", profile)
        recorder = TlogRecorder(log, profile, read_profile_text("sabertooth-dh2")[0])
        procedure = Procedure(profile, confirmed=True, verify=lambda hold: verify_hold(
            hold, profile, estimate, proposal.slots))
        result = await Session(link, profile, recorder=recorder, presenters=[],
                               procedure=procedure, wall_clock=False).run()
        assert result.phase.value == "done", result.reason

    asyncio.run(old_verify())
    assert main(["replay", str(log), "--json"]) == 1
    err = capsys.readouterr().err
    assert "is a verify hold recorded by an older trimd, without the trim it verified" in err
    assert "Traceback" not in err
