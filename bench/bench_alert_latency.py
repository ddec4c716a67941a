"""How soon a ``trimd serve`` alert reaches the pilot's ground station (issue 26: "within
1 s of the alert").

The set-up of ``tests/app/test_serve_gcs.py``: ``trimd sim`` serving the BlueROV2 Heavy with
a housing flooding (8 N within 8 s after the watch's baseline, at 5×) behind its router to
``trimd serve …?ids=vehicle`` and to MAVProxy 1.8.75, ``TRIMD_ALERT_RUNS`` times (default
3). Measured per run, on the wall clock of this machine [s]: from the alert's time as trimd
logs it (``t_unix`` of the alert in ``/api/alerts``: ``trimd serve`` stores it in its
history just before it hands the STATUSTEXT to its link) to the moment this process read
MAVProxy's printed ``AP: TRIMD heavier …`` line from MAVProxy's stdout (unbuffered, read
line by line as it comes). That spans trimd's outbox, UDP to the simulator's router, the
router's forwarding, MAVProxy's decoding and printing, and the pipe. Also: when the alert
came after the start of the run [s]. Prints that MAVProxy is missing instead where it is.
"""

from __future__ import annotations

import os
import statistics
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from bench.size import size
from tests.app.serve_process import serve_beside_mavproxy
from tests.drivers.mavproxy_dive import AtMavproxy, station_text
from tests.drivers.test_mavlink_mavproxy import mavproxy_installed


def latency_s(run: AtMavproxy) -> float:
    """From trimd's alert to MAVProxy's printed line of it, in ``run`` [s, wall clock]."""
    text = f"AP: {station_text(run.alert)}"
    shown = next(t for t, line in run.lines if line == text)
    return shown - float(run.alert["t_unix"])


def report(runs: Iterable[AtMavproxy]) -> None:
    """Print each run's latency as it comes, then their median and maximum."""
    latencies = []
    for i, run in enumerate(runs):
        latencies.append(latency_s(run))
        print(f"  run {i + 1}: alert {run.alert['t_unix'] - run.started_unix:5.1f} s after "
              f"the start, at MAVProxy {latencies[-1] * 1000:6.1f} ms later "
              f"({run.took:.0f} s wall in all)", flush=True)
    print(f"alert → MAVProxy's printed line over {len(latencies)} run(s): median "
          f"{statistics.median(latencies) * 1000:.1f} ms, max {max(latencies) * 1000:.1f} ms")


def _runs(n: int) -> Iterator[AtMavproxy]:
    for _ in range(n):
        with tempfile.TemporaryDirectory() as tmp:
            yield serve_beside_mavproxy(Path(tmp))[0]


def main() -> None:
    if not mavproxy_installed():
        print("MAVProxy is not installed (make install): nothing measured")
        return
    report(_runs(int(os.environ.get("TRIMD_ALERT_RUNS", size(3, 1)))))
