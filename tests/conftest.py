"""Shared fixtures: the shipped profiles, and a data directory of each test's own (helpers
live in tests/helpers.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

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


@pytest.fixture(scope="session")
def sabertooth() -> Profile:
    return load_profile(PROFILES / "sabertooth-dh2.yaml")


@pytest.fixture(scope="session")
def bluerov() -> Profile:
    return load_profile(PROFILES / "bluerov2-heavy.yaml")


#: The modules that take the longest [s of one worker], longest first: the sum of their
#: tests among the 60 slowest of ``--durations=60`` on this 2-core machine under a heavy
#: load (2026-11-27; bench_alert_latency's tiny run since moved into test_serve_gcs's
#: dive), then the older figures of modules with no test among those. Only the order
#: matters: it lets the longest start first, spread over the workers, so that no long
#: module is left to run alone at the end. A module not listed counts as short; a stale
#: figure costs wall time, never a test.
MODULE_COST_S = {
    "tests/app/test_serve.py": 240,
    "tests/tui/test_tui_after_trim.py": 235,
    "tests/app/test_serve_gcs.py": 220,
    "tests/app/test_wander.py": 170,
    "tests/test_bench_smoke.py": 165,
    "tests/drivers/test_mavlink_link.py": 130,
    "tests/drivers/test_mavlink_gcs.py": 128,
    "tests/app/test_serve_browser.py": 125,
    "tests/drivers/test_mavlink_stations.py": 121,
    "tests/app/test_watch_sim.py": 104,
    "tests/app/test_correction.py": 95,
    "tests/app/test_float_check.py": 90,
    "tests/identify/test_staged.py": 90,
    "tests/drivers/test_mavlink_mavproxy.py": 87,
    "tests/drivers/test_serial_link.py": 82,
    "tests/ballast/test_ballast_degenerate.py": 80,
    "tests/drivers/test_sim_disturbance.py": 77,
    "tests/tui/test_tui_snapshots.py": 74,
    "tests/app/test_watch_baseline.py": 70,
    "tests/app/test_verify.py": 67,
    "tests/drivers/test_fuzz_mavlink.py": 60,
    "tests/tui/test_tui.py": 60,
    "tests/drivers/test_serial_protocol.py": 60,
    "tests/tui/test_tui_watch.py": 58,
    "tests/test_package.py": 48,
    "tests/logs/test_replay.py": 45,
    "tests/ballast/test_ballast_props.py": 42,
    "tests/app/test_run_sim.py": 40,
    "tests/cli/test_cli_solve.py": 39,
    "tests/identify/test_excitation.py": 37,
    "tests/tui/test_tui_terminal.py": 36,
    "tests/core/test_estimate.py": 36,
    "tests/identify/test_identify.py": 35,
    "tests/cli/test_cli_watch.py": 34,
    "tests/identify/test_envelope.py": 32,
    "tests/tui/test_tui_replay.py": 32,
    "tests/cli/test_json_contract.py": 30,
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
