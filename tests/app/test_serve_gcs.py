"""``trimd serve`` on the vehicle's companion computer with a leak, MAVProxy beside it
(issue 26's done criterion): MAVProxy prints the alert's STATUSTEXT, and the same alert is
in the service's API and in ``trimd history``.

The set-up of ``tests/drivers/test_mavlink_gcs.py`` (:func:`leak_beside_mavproxy`) with
``trimd serve …?ids=vehicle`` in place of ``trimd watch``. How soon the text reaches
MAVProxy is measured by ``bench/bench_alert_latency.py``, not asserted here."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tests.app.serve_process import Serve, free_tcp_port
from tests.drivers.test_mavlink_gcs import (
    FAST_WATCH,
    AtMavproxy,
    leak_beside_mavproxy,
    station_text,
)
from tests.drivers.test_mavlink_link import TRIMD
from tests.drivers.test_mavlink_mavproxy import needs_mavproxy
from tests.helpers import REPO


def serve_beside_mavproxy(tmp: Path) -> tuple[AtMavproxy, Serve]:
    """Run ``trimd serve`` (its data in ``tmp/data``) beside MAVProxy until MAVProxy has
    printed its alert; the run and the stopped service."""
    http = free_tcp_port()
    started: list[Serve] = []

    def start(profile: Path, port: int) -> subprocess.Popen[bytes]:
        started.append(Serve(
            [sys.executable, "-m", "trimd", "serve", "--link",
             f"mavlink:udpin:127.0.0.1:{port}?ids=vehicle", "--profile", str(profile),
             "--data", str(tmp / "data"), "--host", "127.0.0.1", "--port", str(http),
             *FAST_WATCH], http))
        return started[0].proc

    def alert() -> dict[str, Any] | None:
        alerts = started[0].get("/api/alerts")
        return alerts["alerts"][0] if alerts and alerts["alerts"] else None

    run = leak_beside_mavproxy(tmp, start, alert)
    code = started[0].stop()
    assert code == 0, (code, started[0].output())
    return run, started[0]


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> tuple[AtMavproxy, Serve, Path]:
    """One leaky dive under ``trimd serve`` beside MAVProxy, shared by the tests below:
    the run, the stopped service and its data folder."""
    tmp = tmp_path_factory.mktemp("serve-gcs")
    return (*serve_beside_mavproxy(tmp), tmp / "data")


@pytest.mark.slow
@needs_mavproxy
def test_mavproxy_prints_the_alert_the_api_gives(
        served: tuple[AtMavproxy, Serve, Path]) -> None:
    run, serve, _ = served
    print(f"alert at MAVProxy after {run.took:.0f} s of wall time")
    alert = run.alert                       # the first of /api/alerts
    assert alert["quantity"] == "net_force_N" and alert["total"] > 0
    assert f"AP: {station_text(alert)}" in run.printed.splitlines(), station_text(alert)
    assert "AP: TRIMD watch on: baseline after 2 hovers" in run.printed
    assert f"dive {alert['dive']} started" in serve.output()
    assert f"ALERT: {alert['text']}" in serve.output()


@pytest.mark.slow
@needs_mavproxy
def test_trimd_history_shows_the_alert_mavproxy_printed(
        served: tuple[AtMavproxy, Serve, Path]) -> None:
    run, _, data = served
    shown = subprocess.run([*TRIMD, "history", "--db", str(data / "trimd.db")],
                           capture_output=True, text=True, timeout=120,
                           env={**os.environ, "PYTHONPATH": str(REPO)})
    assert shown.returncode == 0, shown.stderr
    assert run.alert["text"] in shown.stdout, shown.stdout
