"""``trimd serve`` as a process, for the tests: started on a free port, asked over HTTP,
waited on without timed assertions (a generous hang guard only)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.drivers.mavproxy_dive import FAST_WATCH, AtMavproxy, Trimd, leak_beside_mavproxy
from tests.helpers import REPO

#: the longest any wait may take before the test fails as hung [s, wall clock]
HANG_GUARD_S = 180.0
#: a dive whose leak raises an alert soon: 6 N/min from 230 s of simulated time, after the
#: three level segments of the baseline (21–212 s); the second segment after it alerts, at
#: 310 s (2 N/min from 300 s alerted at the third, at 617 s: twice the simulating)
LEAKY_DIVE = "sim:pilot=dive,leak_N_min=6,leak_start_s=230"


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Serve:
    """One ``trimd serve`` process (``argv`` after ``trimd``, or a whole command line)."""

    def __init__(self, argv: list[str], port: int, env: dict[str, str] | None = None) -> None:
        self.port = port
        self.log = Path(os.environ.get("TMPDIR", "/tmp")) / f"trimd-serve-{port}.log"
        self._out = self.log.open("wb")
        self.proc = subprocess.Popen(argv, stdout=self._out, stderr=subprocess.STDOUT,
                                     env={**os.environ, "PYTHONPATH": str(REPO), **(env or {})})

    @classmethod
    def sim(cls, data: Path, link: str = LEAKY_DIVE, *extra: str) -> Serve:
        port = free_tcp_port()
        return cls([sys.executable, "-m", "trimd", "serve", "--link", link, "--profile",
                    "bluerov2-heavy", "--data", str(data), "--host", "127.0.0.1", "--port",
                    str(port), "--sim-rate", "max", *extra], port)

    def get(self, path: str) -> Any:
        """The JSON of ``GET path``, or None while the service does not answer."""
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{self.port}{path}", timeout=10) as r:
                return json.loads(r.read())
        except (urllib.error.URLError, ConnectionError, TimeoutError):
            return None

    def wait_for(self, path: str, until: Callable[[Any], bool]) -> Any:
        """Poll ``path`` until ``until(json)`` holds; the JSON then."""
        deadline = time.monotonic() + HANG_GUARD_S
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise AssertionError(f"trimd serve exited {self.proc.returncode}: "
                                     f"{self.output()}")
            data = self.get(path)
            if data is not None and until(data):
                return data
            time.sleep(0.3)
        raise AssertionError(f"hang guard: {path} never held; output: {self.output()}")

    def output(self) -> str:
        """What the process printed so far (stdout and stderr)."""
        return self.log.read_text(encoding="utf-8", errors="replace")

    def stop(self, sig: int = signal.SIGTERM) -> int:
        """Send ``sig``; the exit code (killed after the hang guard)."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            return self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            raise
        finally:
            self._out.close()


def served_beside_mavproxy(data: Path, comp: int = 191) -> tuple[Trimd, list[Serve]]:
    """``trimd serve …?ids=vehicle&comp=COMP`` (its data in ``data``) as a trimd under test
    beside MAVProxy, and the list its :class:`Serve` goes into once started."""
    http = free_tcp_port()
    started: list[Serve] = []

    def start(profile: Path, port: int) -> subprocess.Popen[bytes]:
        started.append(Serve(
            [sys.executable, "-m", "trimd", "serve", "--link",
             f"mavlink:udpin:127.0.0.1:{port}?ids=vehicle&comp={comp}", "--profile",
             str(profile), "--data", str(data), "--host", "127.0.0.1", "--port", str(http),
             *FAST_WATCH], http))
        return started[0].proc

    def alert() -> dict[str, Any] | None:
        alerts = started[0].get("/api/alerts")
        return alerts["alerts"][0] if alerts and alerts["alerts"] else None

    return (start, alert), started


def serve_beside_mavproxy(tmp: Path) -> tuple[AtMavproxy, Serve]:
    """Run ``trimd serve`` (its data in ``tmp/data``) beside MAVProxy until MAVProxy has
    printed its alert; the run and the stopped service."""
    served, started = served_beside_mavproxy(tmp / "data")
    try:
        run = leak_beside_mavproxy(tmp, [served])
    finally:  # its output file closed however the dive ended
        code = started[0].stop() if started else 0
    assert code == 0, (code, started[0].output())
    return run, started[0]
