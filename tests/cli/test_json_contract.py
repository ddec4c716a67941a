"""The ``--json`` contract (docs/operator.md, "JSON output"): every command that takes
``--json`` prints only JSON lines on stdout — one object per line, each with its
``type``, strict JSON (no NaN or Infinity) — on every kind of log in tests/data: a trimd
recording, ground-station tlogs and a DataFlash log. An error ends the output with an
``error`` line carrying the stderr line and the exit code, never a traceback.

Every command runs once per argument list (:class:`Trimd` keeps the result), in-process.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.cli.test_cli_solve import write_csv
from tests.helpers import ARDUSUB_LOGS, REPO
from trimd.app.jsonlines import json_line
from trimd.app.logholds import log_holds
from trimd.cli.main import main
from trimd.core.profile_yaml import load_profile
from trimd.logs.log import open_log
from trimd.logs.recorder import TRIMD_SYSTEM
from trimd.logs.tlog import TlogReader

GOLDEN = REPO / "tests" / "data" / "golden" / "sabertooth-10kg-aftsb.tlog"
#: The line types each command may print (an error line is allowed for all).
RUN_TYPES = {"state", "info", "warning", "command", "vehicle", "progress", "result",
             "verification"}
TYPES = {"run": RUN_TYPES, "replay": RUN_TYPES | {"log"}, "watch": {"segment", "alert",
         "verdict"}, "inspect": {"log"}, "identify": {"identification"},
         "solve": {"estimate"}, "ballast": {"proposal"}, "apply": {"installed"},
         "history": {"history", "plot"}}


@dataclass(frozen=True)
class Ran:
    """One ``trimd … --json``: its exit code, stdout parsed line by line, and stderr."""

    code: int
    lines: list[dict[str, Any]]
    err: str

    def last(self, kind: str) -> dict[str, Any]:
        assert self.lines and self.lines[-1]["type"] == kind, (self.lines[-1:], self.err)
        return self.lines[-1]


def _not_json(name: str) -> Any:
    raise ValueError(f"{name} is not JSON")


def trimd(*argv: str, as_json: bool = True) -> tuple[int, str, str]:
    """``trimd ARGV [--json]`` in-process: exit code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([*argv, "--json"] if as_json else list(argv))
    return code, out.getvalue(), err.getvalue()


class Trimd:
    """``trimd … --json``, each argument list run once, every stdout line checked
    against the contract."""

    def __init__(self) -> None:
        self._done: dict[tuple[str, ...], Ran] = {}

    def __call__(self, *argv: str) -> Ran:
        if argv not in self._done:
            code, out, err = trimd(*argv)
            assert "Traceback" not in err, err
            lines = [json.loads(line, parse_constant=_not_json) for line in out.splitlines()]
            assert lines, f"trimd {' '.join(argv)} --json printed nothing"
            command = argv[1] if argv[:2] == ("ballast", "apply") else argv[0]
            for line in lines:
                assert isinstance(line, dict), line
                assert line["type"] in TYPES[command] or line is lines[-1], line
            if lines[-1]["type"] == "error":
                assert lines[-1] == {"type": "error", "exit_code": code,
                                     "message": err.strip().splitlines()[-1]}
                assert code != 0
            else:
                assert lines[-1]["type"] in TYPES[command] and code in (0, 1), (code, err)
            self._done[argv] = Ran(code, lines, err)
        return self._done[argv]


def strip_trimd(src: Path, dst: Path) -> Path:
    """The recording as a ground station would have logged the vehicle: without trimd's
    own messages (its profile, commands and notices), so it is no trimd recording."""
    with dst.open("wb") as f:
        for stamp, msg in TlogReader.open(src).messages():
            if msg.get_srcSystem() != TRIMD_SYSTEM:
                f.write(struct.pack(">Q", stamp) + bytes(msg.get_msgbuf()))
    return dst


#: The quick ballast method for replays and runs: the contract is not about the method.
LP = ("--ballast", "lp")


def replay(path: str | Path, profile: str | None = None) -> tuple[str, ...]:
    """``trimd replay`` of ``path`` (a trimd recording needs no profile: it carries it)."""
    return ("replay", str(path), *(("--profile", profile) if profile else ()), *LP)


def run_over(path: str | Path, profile: str) -> tuple[str, ...]:
    """``trimd run`` over a log as its link, confirmed, writing nothing."""
    return ("run", "--link", f"replay:{path}", "--profile", profile, "--yes", "--no-record",
            "--no-history", *LP)


@pytest.fixture(scope="module")
def run() -> Trimd:
    return Trimd()


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("json")


@pytest.fixture(scope="module")
def station_tlog(data: Path) -> Path:
    return strip_trimd(GOLDEN, data / "station.tlog")


#: Each kind of log, with the profile of its vehicle.
LOGS = {"trimd recording": "sabertooth-dh2", "station tlog": "sabertooth-dh2",
        "QGroundControl tlog": "bluerov2-heavy", "DataFlash": "bluerov2-heavy"}


@pytest.fixture(params=list(LOGS))
def log(request: pytest.FixtureRequest, station_tlog: Path) -> tuple[str, str, str]:
    """A kind of log: its name, path and its vehicle's profile."""
    path = {"trimd recording": GOLDEN, "station tlog": station_tlog,
            "QGroundControl tlog": ARDUSUB_LOGS / "mcqueen-small.tlog",
            "DataFlash": ARDUSUB_LOGS / "mcqueen-small.BIN"}[request.param]
    return request.param, str(path), LOGS[request.param]


#: The last line of each command on each kind of log (in the order of :data:`LOGS`): the
#: two logs of a trim give results; the bench logs hold no hold to estimate from (replay:
#: exit 1), none of them an excitation (identify on the bench logs: exit 2), nor a trim a
#: replayed procedure could finish (run on them: the failed state).
LAST = {"inspect": ("log", "log", "log", "log"),
        "replay": ("result", "result", "error", "error"),
        "watch": ("verdict", "verdict", "verdict", "verdict"),
        "run": ("result", "result", "state", "state"),
        "identify": ("identification", "identification", "error", "error")}


@pytest.mark.parametrize("command", list(LAST))
def test_every_log_command_prints_only_json_lines(run: Trimd, data: Path,
                                                  log: tuple[str, str, str],
                                                  command: str) -> None:
    kind, path, profile = log
    argv = {"inspect": ("inspect", path, "--profile", profile),
            "replay": replay(path, None if kind == "trimd recording" else profile),
            "watch": ("watch", path, "--profile", profile, "--db", str(data / "watch.db")),
            "run": run_over(path, profile),
            "identify": ("identify", path, "--profile", profile, "--stage", "uwq",
                         "--segment", "2")}[command]
    ran = run(*argv)
    ran.last(LAST[command][list(LOGS).index(kind)])
    if command == "replay" and kind != "trimd recording":
        assert ran.lines[0]["type"] == "log"   # the report, then the result or why not


def _estimate_text(text: str) -> dict[str, float]:
    """Numbers of the estimate table for people (app/report.format_estimate)."""
    found = {m[0]: float(m[1]) for m in re.findall(
        r"^(weight W|extra mass m_ext|centre of gravity [xyz]_g)\s+(\S+) ±", text, re.M)}
    assert len(found) == 5, text
    return found


def _assert_same_estimate(text: str, estimate: dict[str, Any]) -> None:
    """The text's numbers are the JSON's, rounded as printed (N to 0.01, kg to 0.001,
    mm to 0.01)."""
    shown = _estimate_text(text)
    assert shown["weight W"] == pytest.approx(estimate["weight_N"], abs=0.005)
    assert shown["extra mass m_ext"] == pytest.approx(estimate["m_ext_kg"], abs=0.0005)
    for axis, value in zip("xyz", estimate["cg_m"], strict=True):
        assert shown[f"centre of gravity {axis}_g"] == pytest.approx(1e3 * value, abs=0.005)


def test_the_golden_replay_gives_the_text_path_s_estimate(run: Trimd) -> None:
    result = run(*replay(GOLDEN)).last("result")
    code, text, _ = trimd(*replay(GOLDEN), as_json=False)
    assert code == 0
    _assert_same_estimate(text, result["estimate"])
    expected = json.loads(GOLDEN.with_suffix(".expected.json").read_text(encoding="utf-8"))
    assert result["estimate"]["m_ext_kg"] == pytest.approx(expected["estimate"]["m_ext_kg"])
    # trimd run over the recording as a link: the same result line
    assert run(*run_over(GOLDEN, "sabertooth-dh2")).last("result") == result


def test_a_foreign_log_s_report_lists_the_holds_it_estimates_from(
        run: Trimd, station_tlog: Path) -> None:
    """One detector's view per output: the holds of the report are the estimate's, in
    the JSON lines and in the text, and the estimate finds the hidden 10 kg."""
    ran = run(*replay(station_tlog, "sabertooth-dh2"))
    assert ran.code == 0 and [x["type"] for x in ran.lines] == ["log", "result"]
    report, estimate = ran.lines[0], ran.lines[1]["estimate"]
    assert len(report["holds"]) == 2 and report["no_holds_because"] is None
    assert [(h["label"], h["samples"], h["steady_window_s"]) for h in report["holds"]] == [
        (h["label"], h["samples"], h["steady_window_s"]) for h in estimate["holds"]]
    assert abs(estimate["m_ext_kg"] - 10.0) < 3 * estimate["m_ext_std_kg"]
    assert run("inspect", str(station_tlog), "--profile", "sabertooth-dh2").lines == [report]
    code, text, _ = trimd(*replay(station_tlog, "sabertooth-dh2"), as_json=False)
    assert code == 0 and "No steady attitude holds" not in text
    assert all(f"{h['label']}: roll {h['roll_deg']:.2f}°" in text for h in report["holds"])
    _assert_same_estimate(text, estimate)


@pytest.mark.parametrize("name", ["mcqueen-small.tlog", "mcqueen-small.BIN"])
def test_a_log_without_holds_says_why_and_ends_with_an_error_line(run: Trimd,
                                                                  name: str) -> None:
    ran = run(*replay(ARDUSUB_LOGS / name, "bluerov2-heavy"))
    assert ran.code == 1 and [x["type"] for x in ran.lines] == ["log", "error"]
    why = ran.lines[0]["no_holds_because"]
    assert ran.lines[0]["holds"] == [] and why and why in ran.lines[1]["message"]


def test_solve_ballast_apply_and_history(run: Trimd, data: Path, station_tlog: Path) -> None:
    """The commands that read no log, on what the logs gave: the holds the report lists
    as a CSV, the replay's output as the estimate, a history the watch and apply wrote."""
    profile = load_profile("sabertooth-dh2")
    holds = [h.samples for h in log_holds(list(open_log(station_tlog, profile).samples()),
                                          profile)]
    csv = write_csv(data / "holds.csv", holds, hold_column=True)
    solved = run("solve", str(csv), "--profile", "sabertooth-dh2", "--ballast", "lp"
                 ).last("estimate")
    replayed = run(*replay(station_tlog, "sabertooth-dh2")).lines[-1]
    assert solved["m_ext_kg"] == pytest.approx(replayed["estimate"]["m_ext_kg"], rel=0.01)
    assert solved["ballast"]["slots"]
    est = data / "replay.jsonl"
    est.write_text("\n".join(json.dumps(x) for x in run(*replay(GOLDEN)).lines) + "\n",
                   encoding="utf-8")
    db = str(data / "history.db")
    proposal = run("ballast", "--profile", "sabertooth-dh2", "--estimate", str(est), "--db", db,
                   "--method", "lp").last("proposal")
    assert proposal["slots"] == run(*replay(GOLDEN)).lines[-1]["proposal"]["slots"]
    installed = run("ballast", "apply", "--profile", "sabertooth-dh2", "--estimate", str(est),
                    "--db", db).last("installed")
    assert installed["vehicle"] == "sabertooth-dh2" and installed["installed"]
    [vehicle] = run("history", "--db", db).last("history")["vehicles"]
    assert vehicle["vehicle"] == "sabertooth-dh2" and len(vehicle["installed"]) == 1
    plot = run("history", "--db", db, "--plot", str(data / "history.png")).last("plot")
    assert plot["vehicle"] == "sabertooth-dh2" and Path(plot["file"]).stat().st_size > 0
    assert run("history", "--db", str(data / "none.db")).last("history")["vehicles"] == []


def test_identify_s_line_is_the_summary_and_the_fragment(run: Trimd) -> None:
    ran = run("identify", str(GOLDEN), "--profile", "sabertooth-dh2", "--stage", "uwq",
              "--segment", "2")
    line = ran.last("identification")
    stage = line["stages"]["uwq"]
    assert ran.code == 1 and stage["not_excited"]   # a trim does not excite surge and heave
    fragment = yaml.safe_load(line["fragment"])
    assert fragment["damping"]["quadratic"]["pitch"] == pytest.approx(
        stage["parameters"]["M_q|q|"]["value"], rel=1e-5)


@pytest.mark.parametrize("argv", [
    ("inspect", "missing.tlog"),
    ("replay", "missing.tlog"),
    ("replay", str(ARDUSUB_LOGS / "mcqueen-small.tlog")),            # no --profile
    ("watch", "missing.tlog", "--profile", "sabertooth-dh2", "--no-history"),
    ("watch", "--profile", "sabertooth-dh2"),                         # neither log nor link
    ("run", "--link", "replay:missing.tlog", "--profile", "sabertooth-dh2", "--yes",
     "--no-record", "--no-history"),
    ("run", "--link", "nowhere:x", "--profile", "sabertooth-dh2", "--yes", "--no-record",
     "--no-history"),
    ("identify", "missing.tlog", "--profile", "sabertooth-dh2", "--stage", "uvr"),
    ("solve", "missing.csv", "--profile", "sabertooth-dh2"),
    ("solve", str(GOLDEN), "--profile", "sabertooth-dh2"),               # not a CSV
    ("ballast", "--profile", "sabertooth-dh2", "--estimate", "missing.json"),
    ("ballast", "--profile", "sabertooth-dh2"),                        # no --estimate
    ("ballast", "--profile", "sabertooth-dh2", "--estimate", str(GOLDEN)),  # not text
    ("ballast", "apply", "--profile", "sabertooth-dh2", "--estimate", "missing.json"),
    ("history", "--db", str(GOLDEN)),                                  # not a database
    ("inspect", str(GOLDEN), "--profile", "no-such-profile"),
    ("replay", str(GOLDEN), "--profile", "no-such-profile"),
    ("solve", "--profile", "sabertooth-dh2"),                          # no CSV
    ("inspect", str(GOLDEN), "--no-such-option"),
])
def test_a_user_error_is_an_error_line(run: Trimd, argv: tuple[str, ...]) -> None:
    ran = run(*argv)
    error = ran.last("error")
    assert ran.code in (2, 3) and len(ran.lines) == 1, ran.lines
    assert error["message"].startswith("trimd")


def test_without_json_the_error_is_on_stderr_only() -> None:
    code, out, err = trimd("solve", "missing.csv", "--profile", "sabertooth-dh2",
                           as_json=False)
    assert code == 2 and out == "" and err.startswith("trimd: error: missing.csv")


def test_non_finite_numbers_are_null() -> None:
    """Python's json would print NaN and Infinity, which are not JSON (and which
    :class:`Trimd` refuses in every line above)."""
    line = json_line({"type": "x", "nan": math.nan, "values": [1.5, -math.inf, (math.inf,)]})
    assert json.loads(line, parse_constant=_not_json) == {
        "type": "x", "nan": None, "values": [1.5, None, [None]]}
