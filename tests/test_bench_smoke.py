"""Every benchmark module runs to its end (``make bench`` cannot rot): each as ``make bench``
runs it (``python -m bench NAME``, a process of its own) at the tiny size of
``TRIMD_BENCH_TINY=1`` (:mod:`bench.size`), whose figures mean nothing: only that the
module gets through every step and prints its lines. A module whose tiny run would repeat
another test's set-up is measured on that test's run instead (:data:`RUN_ELSEWHERE`)."""

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


@pytest.mark.parametrize("name", [m for m in MODULES if m not in RUN_ELSEWHERE])
def test_the_benchmark_runs_to_its_end_at_a_tiny_size(name: str) -> None:
    env = {**os.environ, "TRIMD_BENCH_TINY": "1", "PYTHONPATH": str(REPO)}
    proc = subprocess.run([sys.executable, "-m", "bench", name], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, (proc.stdout[-2000:], proc.stderr[-3000:])
    lines = proc.stdout.splitlines()
    assert lines[0] == f"== {name}", lines[:3]          # that module, and only it
    assert not any(line.startswith("== ") for line in lines[1:]), lines
    assert len(lines) >= 2, proc.stdout                 # and it printed its figures
