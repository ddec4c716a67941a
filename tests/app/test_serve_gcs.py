"""``trimd serve`` on the vehicle's companion computer with a leak, MAVProxy beside it
(issue 26's done criterion): MAVProxy prints the alert's STATUSTEXT, and the same alert is
in the service's API and in ``trimd history``.

The set-up of ``tests/drivers/test_mavlink_gcs.py`` (:func:`leak_beside_mavproxy`) with
``trimd serve …?ids=vehicle`` in place of ``trimd watch``. How soon the text reaches
MAVProxy is measured by ``bench/bench_alert_latency.py``, not asserted here; its tiny run
(``tests/test_bench_smoke.py``) is the measurement of this module's dive, the same set-up."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from bench.bench_alert_latency import report
from tests.app.serve_process import serve_beside_mavproxy
from tests.drivers.test_mavlink_gcs import LEAK_N, station_text
from tests.drivers.test_mavlink_link import TRIMD
from tests.drivers.test_mavlink_mavproxy import needs_mavproxy
from tests.helpers import REPO


@pytest.mark.slow
@needs_mavproxy
def test_mavproxy_prints_the_alert_the_api_and_history_give(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One leaky dive under ``trimd serve`` beside MAVProxy (one test, so that the dive
    runs once: a module fixture runs once per xdist worker that takes one of its tests):
    MAVProxy prints the alert of /api/alerts and the watch's start; the service logged
    both; ``trimd history`` shows the alert; and ``bench/bench_alert_latency.py`` at its
    tiny size measures this dive (the bench's own runs are :func:`serve_beside_mavproxy`
    too; its figures mean nothing here)."""
    run, serve = serve_beside_mavproxy(tmp_path)
    print(f"alert at MAVProxy after {run.took:.0f} s of wall time")
    alert = run.alert                       # the first of /api/alerts
    assert alert["quantity"] == "net_force_N"
    assert abs(alert["total"] - LEAK_N) < 3 * alert["total_std"], alert
    assert f"AP: {station_text(alert)}" in run.printed.splitlines(), station_text(alert)
    assert "AP: TRIMD watch on: baseline after 2 hovers" in run.printed
    assert f"dive {alert['dive']} started" in serve.output()
    assert f"ALERT: {alert['text']}" in serve.output()

    shown = subprocess.run([*TRIMD, "history", "--db", str(tmp_path / "data" / "trimd.db")],
                           capture_output=True, text=True, timeout=120,
                           env={**os.environ, "PYTHONPATH": str(REPO)})
    assert shown.returncode == 0, shown.stderr
    assert alert["text"] in shown.stdout, shown.stdout

    capsys.readouterr()
    report([run])
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[0].startswith("  run 1: alert "), lines
    assert lines[1].startswith("alert → MAVProxy's printed line over 1 run(s): median"), lines
