"""``trimd serve`` on a long simulated dive: its memory and whether every segment is stored.

One ``trimd serve`` process follows the simulated BlueROV2 Heavy (``sim:pilot=dive``, as
fast as the machine goes) for ``TRIMD_SERVE_HOURS`` (default 2) simulated hours, asked over
HTTP like the page asks it. Every ``TRIMD_SERVE_EVERY_S`` (default 600) s of dive time: the
process's resident memory (VmRSS, Linux) [MB] and the segments the watch found. At the end:
the RSS growth from the first mark to the last, and the segments the watch found against
those stored in the history (``/api/segments``). One simulated hour takes ≈ 2–10 min of
one core, as loaded as the machine is.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

from bench.size import size

REPO = Path(__file__).resolve().parent.parent
#: How often the status is asked [s of wall time]: the simulated dive runs on as fast as
#: it goes in between (at the tiny size a few simulated seconds, not a minute, past its end).
POLL_S = size(1.0, 0.25)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _get(port: int, path: str) -> Any:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=60) as r:
        return json.loads(r.read())


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def main() -> None:
    hours = float(os.environ.get("TRIMD_SERVE_HOURS", size(2.0, 0.025)))
    every_s = float(os.environ.get("TRIMD_SERVE_EVERY_S", size(600.0, 45.0)))
    port = _free_port()
    with tempfile.TemporaryDirectory() as data:
        proc = subprocess.Popen(
            [sys.executable, "-m", "trimd", "serve", "--link", "sim:pilot=dive,seed=4",
             "--profile", "bluerov2-heavy", "--data", data, "--host", "127.0.0.1", "--port",
             str(port), "--sim-rate", "max"], env={**os.environ, "PYTHONPATH": str(REPO)},
            stderr=subprocess.DEVNULL)
        marks: list[tuple[float, float, int]] = []
        t0, dive = time.monotonic(), None
        try:
            while dive is None or dive["duration_s"] < hours * 3600:
                time.sleep(POLL_S)
                if proc.poll() is not None:
                    raise RuntimeError(f"trimd serve exited {proc.returncode}")
                try:
                    dive = _get(port, "/api/status")["dive"]
                except OSError:
                    continue
                if dive is not None and dive["duration_s"] >= (len(marks) + 1) * every_s:
                    marks.append((dive["duration_s"], _rss_mb(proc.pid), dive["segments"]))
                    print(f"  dive {marks[-1][0]:7.0f} s: RSS {marks[-1][1]:6.1f} MB, "
                          f"{marks[-1][2]} segments ({time.monotonic() - t0:.0f} s wall)",
                          flush=True)
            stored = len(_get(port, "/api/segments")["segments"])
        finally:
            proc.terminate()
            proc.wait(timeout=60)
    assert dive is not None
    print(f"{hours:g} h of simulated diving: RSS {marks[0][1]:.1f} → {marks[-1][1]:.1f} MB "
          f"(growth {marks[-1][1] - marks[0][1]:+.1f} MB from {marks[0][0]:.0f} s to "
          f"{marks[-1][0]:.0f} s); segments found {dive['segments']}, stored {stored}")
