"""Every benchmark module runs to its end (``make bench`` cannot rot): as ``make bench`` runs
them (``python -m bench NAME …``, one process for all: 44 CPU-s here, where a process each
took 75, most of the difference the imports) at the tiny size of ``TRIMD_BENCH_TINY=1``
(:mod:`bench.size`), whose figures mean nothing: only that each module gets through every
step and prints its lines. A module whose tiny run would repeat another test's set-up is
measured on that test's run instead (:data:`RUN_ELSEWHERE`)."""

from __future__ import annotations

import os
import pkgutil
import subprocess
import sys

import pytest

from tests.helpers import REPO

pytestmark = pytest.mark.slow

MODULES = sorted(m.name for m in pkgutil.iter_modules([str(REPO / "bench")])
                 if m.name.startswith("bench_"))
#: module → the test that runs its measurement on a run the test makes anyway: one served
#: dive beside MAVProxy (two minutes of wall time) instead of two
RUN_ELSEWHERE = {"bench_alert_latency": (
    "tests/app/test_serve_gcs.py",
    "test_mavproxy_prints_the_alerts_of_the_watch_and_the_service_beside_it")}


def test_every_benchmark_module_is_found() -> None:
    assert len(MODULES) >= 12 and {"bench_session", "bench_sim_coverage",
                                 "bench_calibration"} <= set(MODULES)
    for name, (path, test) in RUN_ELSEWHERE.items():
        assert name in MODULES and f"def {test}(" in (REPO / path).read_text(encoding="utf-8")


def test_every_benchmark_runs_to_its_end_at_a_tiny_size() -> None:
    names = [m for m in MODULES if m not in RUN_ELSEWHERE]
    env = {**os.environ, "TRIMD_BENCH_TINY": "1", "PYTHONPATH": str(REPO)}
    proc = subprocess.run([sys.executable, "-m", "bench", *names], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, (proc.stdout[-2000:], proc.stderr[-3000:])
    lines = proc.stdout.splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("== ")]
    # those modules, and only they, in turn: each printed its figures
    assert [lines[i] for i in starts] == [f"== {name}" for name in names], lines[:3]
    for name, begin, end in zip(names, starts, [*starts[1:], len(lines)], strict=True):
        assert end - begin >= 2, (name, lines[begin:end])


def test_an_unknown_calibration_group_is_named_before_any_seed_runs(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from bench.bench_calibration import GROUPS, known_groups

    monkeypatch.setenv("TRIMD_CALIB_KNOWN", "vertical, gain")
    with pytest.raises(ValueError, match="no group gain") as raised:
        known_groups()
    assert all(g in str(raised.value) for g in GROUPS)
    monkeypatch.setenv("TRIMD_CALIB_KNOWN", " gains,vertical ")
    assert known_groups() == ["gains", "vertical"]
