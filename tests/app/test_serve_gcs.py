"""``trimd watch`` and ``trimd serve`` on the vehicle's companion computer as a housing
floods, MAVProxy beside them (issue 26's done criterion): MAVProxy prints each one's alert
and the watch's values, the service's alert is in its API and in ``trimd history``, and
neither sends MAVProxy anything but its heartbeat, stream requests, texts and values.

The set-up is :mod:`tests.drivers.mavproxy_dive`'s, with both trimds on one simulated dive
(one test, so that the 85 s dive runs once: a module fixture would run once per xdist
worker that takes one of its tests). How soon the text reaches MAVProxy is measured by
``bench/bench_alert_latency.py``, not asserted here; its tiny run (``tests/
test_bench_smoke.py``) is the measurement of this dive."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from bench.bench_alert_latency import report
from tests.app.serve_process import served_beside_mavproxy
from tests.drivers.mavproxy_dive import (
    LEAK_N,
    VALUE,
    leak_beside_mavproxy,
    sent_by,
    station_text,
    texts_from,
    watch_beside_mavproxy,
)
from tests.drivers.test_mavlink_announce import WATCH_SENDS
from tests.drivers.test_mavlink_link import TRIMD
from tests.drivers.test_mavlink_mavproxy import needs_mavproxy
from tests.helpers import REPO
from trimd.logs.tlog import TlogReader

#: the service's component: the watch is the companion's usual 191
SERVE_COMP = 192


@pytest.mark.slow
@needs_mavproxy
def test_mavproxy_prints_the_alerts_of_the_watch_and_the_service_beside_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    watched, records = watch_beside_mavproxy(tmp_path)
    served, started = served_beside_mavproxy(tmp_path / "data", SERVE_COMP)
    try:
        run = leak_beside_mavproxy(tmp_path, [served, watched])
    finally:
        code = started[0].stop() if started else 0
    serve = started[0]
    assert code == 0, (code, serve.output())
    printed, lines = run.printed, run.printed.splitlines()
    print(f"both alerts at MAVProxy after {run.took:.0f} s of wall time")
    print("\n".join(x for x in lines if "TRIMD" in x))

    serve_alert, watch_alert = run.alerts       # serve's first: the bench reads run.alert
    assert watch_alert["component"] == 0 and serve_alert["quantity"] == "net_force_N"
    # each alert: the water, against a baseline formed before it came in, as MAVProxy
    # printed it (once, when the two texts are the same) and as each sent it
    for alert, comp in zip(run.alerts, (SERVE_COMP, 191), strict=True):
        assert abs(alert["total"] - LEAK_N) < 3 * alert["total_std"], alert
        assert f"AP: {station_text(alert)}" in lines, station_text(alert)
        texts = texts_from(run.tlog, 1, comp)
        assert station_text(alert) in texts, (comp, texts)
        assert "TRIMD watch on: baseline after 2 hovers" in texts, (comp, texts)
    assert "AP: TRIMD watch on: baseline after 2 hovers" in lines

    # each W − B that reached MAVProxy from the watch is one of its segments' (float32 on
    # the wire), and MAVProxy printed it and the other two values
    segments = [r["net_force_N"] for r in records() if r["type"] == "segment"]
    sent = [m.value for _, m in TlogReader.open(run.tlog).messages()
            if m.get_type() == "NAMED_VALUE_FLOAT" and m.name == "TRIMD_WB"
            and (m.get_srcSystem(), m.get_srcComponent()) == (1, 191)]
    shown = [float(v) for name, v in VALUE.findall(printed) if name == "TRIMD_WB"]
    assert sent and all(min(abs(v - s) for s in segments) < 1e-4 for v in sent), (
        sent, segments)
    assert all(min(abs(v - p) for p in shown) < 1e-6 for v in sent), (sent, shown)
    assert {name for name, _ in VALUE.findall(printed)} == {"TRIMD_WB", "TRIMD_MX",
                                                            "TRIMD_MY"}

    # from each trimd's ids MAVProxy got the watch's set and no command but stream rates
    for comp in (191, SERVE_COMP):
        kinds = sent_by(run.tlog, 1, comp)
        print(comp, {k: sorted(v) for k, v in kinds.items()})
        assert set(kinds) - {"REQUEST_DATA_STREAM"} == WATCH_SENDS, comp
        assert kinds["COMMAND_LONG"] == {mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL}
        assert kinds["HEARTBEAT"] == {mavlink2.MAV_TYPE_ONBOARD_CONTROLLER}

    # the service logged the dive and its alert; trimd history shows it
    assert f"dive {serve_alert['dive']} started" in serve.output()
    assert f"ALERT: {serve_alert['text']}" in serve.output()
    shown_history = subprocess.run(
        [*TRIMD, "history", "--db", str(tmp_path / "data" / "trimd.db")],
        capture_output=True, text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert shown_history.returncode == 0, shown_history.stderr
    assert serve_alert["text"] in shown_history.stdout, shown_history.stdout

    # bench/bench_alert_latency.py at its tiny size measures this dive (its own runs are
    # serve_beside_mavproxy's, the service alone; the figures mean nothing here)
    capsys.readouterr()
    report([run])
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 2 and out[0].startswith("  run 1: alert "), out
    assert out[1].startswith("alert → MAVProxy's printed line over 1 run(s): median"), out
