"""``trimd serve`` on the simulated BlueROV2 Heavy with a leak, as a process: the JSON API,
the alert in the API and in ``trimd history``, a ``kill -9`` mid-dive that loses no stored
record, and the BlueOS extension's entry point run exactly as its Dockerfile runs it.

The simulator runs in the service's process as fast as it goes (``--sim-rate max``);
nothing is timed: each test waits for what it checks, with a generous hang guard."""

from __future__ import annotations

import json
import os
import re
import shlex
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tests.app.serve_process import Serve, free_tcp_port
from tests.drivers.test_mavlink_link import TRIMD
from tests.helpers import REPO
from trimd import __version__
from trimd.app.serve import DEFAULT_PORT
from trimd.cli.main import main

DOCKERFILE = REPO / "blueos" / "Dockerfile"


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _check_segment(s: dict[str, Any], dive: str) -> None:
    assert s["type"] == "segment" and s["dive"] == dive
    assert _is_number(s["t_unix"]) and s["time_utc"].endswith(" UTC")
    assert s["t_start_s"] < s["t_end_s"] and isinstance(s["baseline"], bool)
    assert _is_number(s["net_force_N"]) and s["net_force_std_N"] > 0
    assert len(s["net_moment_Nm"]) == 3 and len(s["cov_net"]) == 4


@pytest.mark.slow
def test_the_api_during_a_leaky_dive_and_trimd_history(tmp_path: Path) -> None:
    serve = Serve.sim(tmp_path)
    try:
        status = serve.wait_for("/api/status", lambda s: s["dive"] is not None)
        assert status["connected"] and status["armed"] and status["mode"] == "ALT_HOLD"
        assert status["passive"] is True and status["db"] == str(tmp_path / "trimd.db")
        dive = status["dive"]["id"]
        alerts = serve.wait_for("/api/alerts", lambda a: a["alerts"])["alerts"]
        alert = alerts[0]
        assert alert["type"] == "alert" and alert["quantity"] == "net_force_N"
        assert alert["total"] > 0 and alert["dive"] == dive
        assert alert["text"].startswith("heavier by")
        segments = serve.get("/api/segments")
        assert segments["dive"] == dive and segments["running"] is True
        assert len(segments["segments"]) >= 3
        for s in segments["segments"]:
            _check_segment(s, dive)
        assert [a["text"] for a in segments["alerts"]] == [a["text"] for a in alerts]
        base = segments["baseline"]
        assert len(base["q"]) == len(base["std"]) == 3 and base["std"][0] > 0
        assert serve.get(f"/api/segments?dive={dive}")["dive"] == dive
        dives = serve.get("/api/dives")["dives"]
        assert [d["id"] for d in dives] == [dive] and dives[0]["running"]
        assert Path(dives[0]["recording"]).stat().st_size > 0
        history = serve.get("/api/history")
        assert history["vehicles"][0]["vehicle"] == "bluerov2-heavy"
        assert history["vehicles"][0]["alerts"][0]["text"] == alert["text"]
        assert serve.get("/register_service")["webpage"] == "/"
    finally:
        assert serve.stop() == 0, serve.output()
    assert f"dive {dive} ended" in serve.output()
    shown = subprocess.run([*TRIMD, "history", "--db", str(tmp_path / "trimd.db")],
                           capture_output=True, text=True, timeout=120,
                           env={**os.environ, "PYTHONPATH": str(REPO)})
    assert shown.returncode == 0, shown.stderr
    assert alert["text"] in shown.stdout


@pytest.mark.slow
def test_a_kill_9_mid_dive_loses_no_stored_record(tmp_path: Path) -> None:
    serve = Serve.sim(tmp_path)
    try:
        serve.wait_for("/api/segments", lambda d: len(d["segments"]) >= 3)
        before = serve.get("/api/history")
    finally:
        assert serve.stop(signal.SIGKILL) == -signal.SIGKILL
    again = Serve.sim(tmp_path, "sim:pilot=dive,seed=2")
    try:
        status = again.wait_for("/api/status", lambda s: s["dive"] is not None)
        after = again.get("/api/history")
        dives = again.get("/api/dives")["dives"]
    finally:
        assert again.stop() == 0, again.output()
    old, new = before["vehicles"][0], after["vehicles"][0]
    for kind in ("watch_segments", "alerts"):
        assert new[kind][:len(old[kind])] == old[kind]
    # the killed dive is listed with its records and recording; the new one runs
    killed = before["vehicles"][0]["watch_segments"][0]["dive"]
    assert dives[0]["id"] == killed and dives[-1]["id"] == status["dive"]["id"]
    # its recording, cut by the kill, is a log trimd watch reads
    replay = subprocess.run([*TRIMD, "watch", dives[0]["recording"], "--profile",
                             "bluerov2-heavy", "--json", "--no-history"], capture_output=True,
                            text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert replay.returncode == 0, replay.stderr
    assert any(json.loads(line)["type"] == "segment" for line in replay.stdout.splitlines())


def _instructions() -> list[tuple[str, str]]:
    """The extension's Dockerfile as (instruction, its arguments), lines joined."""
    text = DOCKERFILE.read_text(encoding="utf-8").replace("\\\n", " ")
    return [(word, rest) for word, _, rest in (line.strip().partition(" ") for line in
                                                text.splitlines()) if word.isupper()]


def _dockerfile() -> tuple[dict[str, str], list[str]]:
    """The ENV and the CMD (exec form) of the extension's Dockerfile."""
    env: dict[str, str] = {}
    cmd: list[str] = []
    for word, rest in _instructions():
        if word == "ENV":
            env.update(dict(part.split("=", 1) for part in shlex.split(rest)))
        elif word == "CMD":
            cmd = json.loads(rest)
    return env, cmd


#: what a publisher gives ``docker buildx build --build-arg …`` (example.org: no real URL)
BUILD_ARGS = {"AUTHOR": "Ada Diver", "AUTHOR_EMAIL": "ada@example.org",
              "MAINTAINER": "Reef Lab", "MAINTAINER_EMAIL": "lab@example.org",
              "DOCS_URL": "https://example.org/trimd/docs/blueos.md",
              "README_URL": "https://example.org/trimd/{tag}/docs/blueos.md"}


def _labels(build_args: dict[str, str]) -> dict[str, str]:
    """The image's labels as Docker sets them: ``${ARG}`` replaced by ``build_args`` (an
    ARG without a value is an error here), then unquoted as Docker's shell-like words."""
    declared = {a for word, rest in _instructions() if word == "ARG" for a in rest.split()}
    labels: dict[str, str] = {}
    for word, rest in _instructions():
        if word == "LABEL":
            for name in re.findall(r"\$\{(\w+)\}", rest):
                assert name in declared, name
                rest = rest.replace(f"${{{name}}}", build_args[name])
            labels.update(part.split("=", 1) for part in shlex.split(rest))
    return labels


def test_the_blueos_labels_are_the_json_blueos_reads() -> None:
    """BlueOS's extension store reads these labels (json5: JSON is json5), by the schema of
    bluerobotics/BlueOS-Extensions-Repository (``blueos_repository/extension``)."""
    labels = _labels(BUILD_ARGS)
    env, _ = _dockerfile()
    assert labels["version"] == __version__
    permissions = json.loads(labels["permissions"])
    assert permissions["HostConfig"]["NetworkMode"] == "host"
    assert f"{DEFAULT_PORT}/tcp" in permissions["ExposedPorts"]
    assert [b.split(":") for b in permissions["HostConfig"]["Binds"]] == [
        ["/usr/blueos/extensions/trimd", env["TRIMD_DATA_DIR"]]]
    assert json.loads(labels["authors"]) == [{"name": "Ada Diver", "email": "ada@example.org"}]
    company = json.loads(labels["company"])
    assert (company["name"], company["email"]) == ("Reef Lab", "lab@example.org")
    assert company["about"]
    assert labels["type"] in {"device-integration", "example", "theme", "other", "tool",
                              "education"}
    tags = json.loads(labels["tags"])
    assert 0 < len(tags) <= 10 and all(re.fullmatch(r"[a-z0-9-]+", t) for t in tags)
    assert labels["readme"] == BUILD_ARGS["README_URL"] and "{tag}" in labels["readme"]
    assert labels["docs"] == json.loads(labels["links"])["documentation"] == (
        BUILD_ARGS["DOCS_URL"])
    assert re.fullmatch(r"core >= \d+\.\d+", labels["requirements"])


@pytest.mark.parametrize("missing", [None, *BUILD_ARGS])
def test_the_build_stops_without_each_build_arg(missing: str | None) -> None:
    """The Dockerfile's check of its build arguments, run as ``RUN`` runs it (``sh -c``,
    the arguments in the environment): it passes with all, fails naming them without one."""
    check = next(rest for word, rest in _instructions() if word == "RUN" and "test -n" in rest)
    env = {"PATH": os.environ["PATH"], **{k: v for k, v in BUILD_ARGS.items() if k != missing}}
    done = subprocess.run(["sh", "-c", check], env=env, capture_output=True, text=True,
                          timeout=30)
    assert done.returncode == (0 if missing is None else 1), done.stderr
    assert (missing is None) == (done.stderr == ""), done.stderr
    if missing is not None:
        assert missing in done.stderr


@pytest.mark.slow
def test_the_blueos_entry_point_runs_as_the_dockerfile_says(tmp_path: Path) -> None:
    """The CMD with the image's ENV (only the data volume moved to a temporary folder),
    and a simulated ArduSub sending to its MAVLink port as BlueOS's router would; the
    autopilot rebooting (its process stopped and started again) is followed."""
    env, cmd = _dockerfile()
    assert cmd[0] == "trimd" and env["TRIMD_LINK"].startswith("mavlink:udpin:0.0.0.0:")
    port = int(env["TRIMD_LINK"].partition("?")[0].rsplit(":", 1)[1])
    serve = Serve([sys.executable, "-m", "trimd", *cmd[1:]], 8970,
                  {**env, "TRIMD_DATA_DIR": str(tmp_path)})

    def vehicle() -> subprocess.Popen[bytes]:
        return subprocess.Popen([*TRIMD, "sim", "--profile", env["TRIMD_PROFILE"], "--serve",
                                 f"mavlink:udpout:127.0.0.1:{port}", "--rate", "10"],
                                env={**os.environ, "PYTHONPATH": str(REPO)},
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    autopilot = vehicle()
    try:
        status = serve.wait_for("/api/status", lambda s: s["connected"])
        assert status["link"] == env["TRIMD_LINK"] and status["data"] == str(tmp_path)
        assert status["dive"] is None and not status["armed"]   # trimd sim boots disarmed
        service = serve.get("/register_service")
        assert {"name", "description", "icon", "company", "version", "webpage",
                "api"} <= set(service)
        autopilot.terminate()
        autopilot.wait(timeout=30)
        serve.wait_for("/api/status", lambda s: not s["connected"])
        autopilot = vehicle()
        serve.wait_for("/api/status", lambda s: s["connected"])
    finally:
        code = serve.stop()
        autopilot.terminate()
        autopilot.wait(timeout=30)
    assert code == 0, serve.output()


@pytest.mark.parametrize(("argv", "says"), [
    (["--profile", "bluerov2-heavy"], "give --link URL and --profile P"),
    (["--link", "udp:0.0.0.0:14550", "--profile", "bluerov2-heavy"], "mavlink:udp"),
    (["--link", "sim:nonsense=1", "--profile", "bluerov2-heavy"], "nonsense"),
    (["--link", "sim", "--profile", "no-such-profile"], "no-such-profile"),
    (["--link", "sim", "--profile", "bluerov2-heavy", "--port", "70000"], "--port"),
])
def test_bad_input_is_one_clear_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                     capsys: pytest.CaptureFixture[str], argv: list[str],
                                     says: str) -> None:
    monkeypatch.delenv("TRIMD_LINK", raising=False)
    monkeypatch.delenv("TRIMD_PROFILE", raising=False)
    port = ["--port", str(free_tcp_port())]
    code = main(["serve", "--data", str(tmp_path), "--host", "127.0.0.1", *port, *argv])
    err = capsys.readouterr().err
    assert code in (2, 3) and says in err, err
