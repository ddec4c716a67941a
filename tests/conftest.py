"""Shared fixtures: the shipped profiles, and a data directory of each test's own (helpers
live in tests/helpers.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests import shared_runs
from tests.helpers import PROFILES
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile


@pytest.fixture(autouse=True)
def _own_data_dir(tmp_path_factory: pytest.TempPathFactory,
                  monkeypatch: pytest.MonkeyPatch) -> Path:
    """``$TRIMD_DATA_DIR`` in a temporary folder: no test writes session logs or the trim
    history into the user's home."""
    path = tmp_path_factory.mktemp("trimd-data")
    monkeypatch.setenv("TRIMD_DATA_DIR", str(path))
    return path


@pytest.fixture(scope="session", autouse=True)
def _shared_runs(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Runs that several tests make alike (:mod:`tests.shared_runs`) are kept in the test
    run's temporary folder, which the workers of pytest-xdist share (each has a folder of
    its own inside it)."""
    base = tmp_path_factory.getbasetemp()
    shared_runs.DIRECTORY = (base.parent if "PYTEST_XDIST_WORKER" in os.environ
                             else base) / "shared-runs"


@pytest.fixture(scope="session")
def sabertooth() -> Profile:
    return load_profile(PROFILES / "sabertooth-dh2.yaml")


@pytest.fixture(scope="session")
def bluerov() -> Profile:
    return load_profile(PROFILES / "bluerov2-heavy.yaml")


#: The modules that take the longest [s of one worker], longest first: the sum of their
#: tests' wall times in one ``make test`` on this 2-core machine (2026-11-27, after the
#: watch's and the identification's speed-ups; the bench smoke, one test since
#: 2026-11-29, and the MAVProxy dive at 5× measured then). Only the order matters: it lets the
#: longest start first, spread over the workers, so that no long module is left to run
#: alone at the end. A module not listed counts as short; a stale figure costs wall time,
#: never a test.
MODULE_COST_S = {
    "tests/app/test_serve_gcs.py": 88,
    "tests/drivers/test_mavlink_link.py": 87,
    "tests/test_bench_smoke.py": 79,
    "tests/drivers/test_mavlink_stations.py": 74,
    "tests/identify/test_staged.py": 61,
    "tests/tui/test_tui_after_trim.py": 43,
    "tests/core/test_estimate.py": 38,
    "tests/drivers/test_serial_link.py": 34,
    "tests/app/test_watch_sim.py": 34,
    "tests/app/test_float_check.py": 33,
    "tests/identify/test_identify.py": 32,
    "tests/tui/test_tui.py": 32,
    "tests/app/test_run_sim.py": 32,
    "tests/drivers/test_mavlink_mavproxy.py": 31,
    "tests/cli/test_cli_watch.py": 29,
    "tests/app/test_wander.py": 23,
    "tests/tui/test_tui_snapshots.py": 20,
    "tests/app/test_serve.py": 20,
    "tests/app/test_verify.py": 20,
    "tests/logs/test_replay.py": 19,
    "tests/app/test_correction.py": 17,
    "tests/drivers/test_sim_disturbance.py": 16,
    "tests/drivers/test_serial_protocol.py": 13,
    "tests/cli/test_inspect.py": 13,
    "tests/drivers/test_fuzz_mavlink.py": 12,
    "tests/ballast/test_ballast_degenerate.py": 12,
    "tests/app/test_calibration_history.py": 12,
    "tests/ballast/test_ballast_props.py": 12,
    "tests/app/test_calibration.py": 11,
}


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under pytest-xdist, order the collection so that each worker's first share (``--dist
    worksteal`` hands worker k the k-th of equal shares, then moves tests from the end of
    the longest queue) starts with its lane of the long modules, dealt longest first in
    turn. A module's tests stay together and in order (a module fixture is set up once per
    worker that runs them). Without xdist the order is left as collected."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0"))
    if workers < 2:
        return
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        modules.setdefault(item.nodeid.split("::")[0], []).append(item)
    long = sorted((m for m in modules if m in MODULE_COST_S), key=lambda m: -MODULE_COST_S[m])
    lanes: list[list[pytest.Item]] = [[] for _ in range(workers)]
    load = [0.0] * workers
    for m in long:                              # each to the lane with the least so far
        k = load.index(min(load))
        lanes[k] += modules[m]
        load[k] += MODULE_COST_S[m]
    short = [item for m, its in modules.items() if m not in MODULE_COST_S for item in its]
    ordered: list[pytest.Item] = []
    pending, end = len(items), 0
    for k in range(workers):        # the shares worksteal sends: pending // nodes remaining
        end += pending // (workers - k)
        pending -= pending // (workers - k)
        ordered += lanes[k]
        take = max(0, end - len(ordered))
        ordered += short[:take]
        short = short[take:]
    items[:] = ordered + short
