"""A BlueROV2 with trimd on its companion computer, MAVProxy beside it, and a housing that
floods: the set-up of ``tests/app/test_serve_gcs.py`` and ``bench/bench_alert_latency.py``.

``trimd sim`` serves the simulated Heavy on endpoints behind one router (as BlueOS's
mavlink-router does): each trimd under test on one (``trimd watch …?ids=vehicle``, a
component of the vehicle, 1/191; ``trimd serve …?ids=vehicle&comp=192``), MAVProxy 1.8.75
on another (the pilot's ground station, its console and tlog), and a helper on the last
(it switches the simulator's pilot-input failsafe off and arms the vehicle in ALT_HOLD:
nobody flies it). MAVProxy prints the vehicle's STATUSTEXT (``AP: …``) and, asked to
(``watch NAMED_VALUE_FLOAT``), the named values; its tlog holds every packet trimd sent
through the router. MAVProxy is told the vehicle's system (``--target-system=1``): left to
find it, it takes the first autopilot heartbeat's component too (1/1) and then shows
nothing of the vehicle's other components.

The served simulator runs :data:`RATE` (5) times faster than the wall clock the live watch
measures on, so the watch cuts 11 s segments (55 simulated seconds each) and forms its
baseline from two.
Nothing is timed: :func:`leak_beside_mavproxy` waits for what MAVProxy prints, with a
generous hang guard.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.drivers.test_mavlink_link import (
    TRIMD,
    fast_profile,
    free_udp_port,
    switch_off_pilot_failsafe,
    wait_bound,
)
from tests.drivers.test_mavlink_mavproxy import MAVPROXY
from tests.helpers import REPO
from trimd.app.announce import alert_text
from trimd.core.change import ChangeAlert
from trimd.drivers.mavlink.statustext import ascii_text
from trimd.drivers.sim.mavlink_server import open_mavlink2
from trimd.logs.tlog import TlogReader

HANG_GUARD_S = 400.0       # the whole run; not a timed assertion
#: how many times faster than the wall clock the simulator runs (the suite's CPU goes with
#: the simulated time: at 10× this dive took 67 CPU-s, 4 processes beside MAVProxy)
RATE = 5
#: a flooding housing: 8 N of water within 8 s from 240 s of simulated time (48 s of wall
#: time; the watch's baseline is formed by ≈ 38 s: the depth settles from arming, 5 s of
#: quiet, the settling test, two 11 s segments); the first whole segment after it alerts.
#: (A leak of 2 N/min alerted only at the fifth segment after it, each segment's ± widened
#: by the water coming in during it: twice the dive; one of 4 N needed two segments.)
LEAK = "leak_N_min=60,leak_start_s=240,leak_max_N=8"
#: the water that came in [N]
LEAK_N = 8.0
#: the watch's options: 11 s segments (just above the shortest allowed; 55 s of simulated
#: time), a baseline of two
FAST_WATCH = ("--max-segment", "11", "--baseline-segments", "2")
VALUE = re.compile(r"^< NAMED_VALUE_FLOAT \{.*name : (\w+), value : ([-\d.e+]+)", re.M)


def arm(port: int) -> None:
    """Through the simulator's endpoint ``port``: COMMAND_LONG arm, until accepted."""
    conn = open_mavlink2(f"udpin:127.0.0.1:{port}", 254, 1)
    deadline = time.monotonic() + HANG_GUARD_S
    try:
        while time.monotonic() < deadline:
            conn.mav.command_long_send(1, 1, mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                       1, 0, 0, 0, 0, 0, 0)
            ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5)
            if ack is not None and ack.command == mavlink2.MAV_CMD_COMPONENT_ARM_DISARM:
                assert ack.result == mavlink2.MAV_RESULT_ACCEPTED
                return
        raise AssertionError("the vehicle never answered the arm command")
    finally:
        conn.close()


def _stop(procs: list[subprocess.Popen[bytes]]) -> None:
    """SIGTERM to each in turn, killed after 60 s (a hang guard: a watch starved of CPU
    takes a while to close its last segment): trimd first, while the vehicle still talks
    (it stops at its next sample), the simulator last."""
    for p in procs:
        t0 = time.monotonic()
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        print(f"{' '.join(map(str, p.args[2:4]))} stopped in {time.monotonic() - t0:.1f} s")


def _first_alert(watch_out: Path) -> dict[str, Any] | None:
    lines = watch_out.read_text(encoding="utf-8").splitlines()
    records = [json.loads(x) for x in lines if x.startswith("{") and x.endswith("}")]
    return next((r for r in records if r["type"] == "alert"), None)


def station_text(d: dict[str, Any]) -> str:
    """The STATUSTEXT a ground station prints for a watch's JSON alert (ASCII):
    ``TRIMD heavier 2.4+-0.1N since 5min: water?``."""
    alert = ChangeAlert(d["component"], d["total"], d["total_std"], d["change"],
                        d["change_std"], math.nan if d["after_s"] is None else d["after_s"],
                        d["since_s"], d["t_s"], d["segments"], d["statistic"], d["first"])
    return ascii_text(alert_text(alert).text)


@dataclass
class AtMavproxy:
    """What a run beside MAVProxy gave: each line MAVProxy printed with the wall time it
    was read [s since the Unix epoch], each trimd's first alert (as that trimd gave it),
    MAVProxy's tlog, when the run started [s since the Unix epoch] and the wall time it
    took [s]."""

    lines: list[tuple[float, str]]
    alerts: list[dict[str, Any]]
    tlog: Path
    started_unix: float
    took: float

    @property
    def alert(self) -> dict[str, Any]:
        """The first trimd's alert."""
        return self.alerts[0]

    @property
    def printed(self) -> str:
        return "\n".join(line for _, line in self.lines)


#: A trimd under test: ``start(profile, port)`` starts it listening on UDP ``port`` with
#: the profile (the Heavy's, fast holds) at ``profile``; ``alert()`` is its first alert
#: (None before it).
Trimd = tuple[Callable[[Path, int], "subprocess.Popen[bytes]"],
              Callable[[], "dict[str, Any] | None"]]


def _read_lines(stream: IO[bytes], into: list[tuple[float, str]]) -> None:
    """Each line of ``stream`` into ``into`` with the wall time it was read, until EOF."""
    for raw in stream:
        into.append((time.time(), raw.decode("utf-8", errors="replace").rstrip("\n")))


def leak_beside_mavproxy(tmp: Path, trimds: Sequence[Trimd]) -> AtMavproxy:
    """Run the set-up until MAVProxy has printed each trimd's alert, and values (MAVProxy
    prints a text only once when two components send the same).

    MAVProxy's stdout is read line by line as it comes (it runs unbuffered)."""
    profile = fast_profile(tmp, "bluerov2-heavy")
    trimd_ports = [free_udp_port() for _ in trimds]
    gcs_port, helper_port = free_udp_port(), free_udp_port()
    env = {**os.environ, "PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1"}
    tlog, lines = tmp / "gcs.tlog", []
    procs: list[subprocess.Popen[bytes]] = []
    t0, started_unix = time.monotonic(), time.time()
    with (tmp / "sim.err").open("wb") as err_file:
        try:
            gcs = subprocess.Popen(
                [*MAVPROXY, f"--master=udpin:127.0.0.1:{gcs_port}", "--daemon",
                 "--non-interactive", "--default-modules=", "--target-system=1",
                 f"--logfile={tlog}", f"--state-basedir={tmp}", "--cmd=watch NAMED_VALUE_FLOAT"],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=tmp, env=env)
            procs.append(gcs)
            assert gcs.stdout is not None
            threading.Thread(target=_read_lines, args=(gcs.stdout, lines), daemon=True).start()
            procs[:0] = [start(profile, port)
                         for (start, _), port in zip(trimds, trimd_ports, strict=True)]
            for port in (gcs_port, *trimd_ports):
                wait_bound(port)
            procs.append(subprocess.Popen(
                [*TRIMD, "sim", "--profile", str(profile), "--rate", str(RATE), "--options",
                 f"mode=ALT_HOLD,{LEAK}",
                 *(f"--serve=mavlink:udpout:127.0.0.1:{p}"
                   for p in (*trimd_ports, gcs_port, helper_port))],
                stdout=subprocess.DEVNULL, stderr=err_file, cwd=REPO, env=env))
            switch_off_pilot_failsafe(helper_port)
            arm(helper_port)
            deadline = time.monotonic() + HANG_GUARD_S
            while True:
                printed = "\n".join(line for _, line in lines)
                found = [alert() for _, alert in trimds]
                names = {name for name, _ in VALUE.findall(printed)}
                shown = printed.splitlines()
                if (all(a is not None and f"AP: {station_text(a)}" in shown for a in found)
                        and "TRIMD_WB" in names):
                    break
                dead = [" ".join(map(str, p.args[2:4])) for p in procs if p.poll() is not None]
                assert not dead, (dead, printed[-2000:], (tmp / "sim.err").read_text()[-2000:])
                assert time.monotonic() < deadline, f"hang guard: MAVProxy: {printed[-3000:]}"
                time.sleep(0.5)
            took = time.monotonic() - t0
        finally:
            _stop(procs)
    return AtMavproxy(lines, [a for a in found if a is not None], tlog, started_unix, took)


def watch_beside_mavproxy(tmp: Path) -> tuple[Trimd, Callable[[], list[dict[str, Any]]]]:
    """``trimd watch …?ids=vehicle`` (JSON lines to ``tmp/watch.jsonl``) as a trimd under
    test, and what it wrote (every JSON line)."""
    out = tmp / "watch.jsonl"

    def start(profile: Path, port: int) -> subprocess.Popen[bytes]:
        with out.open("wb") as stdout, (tmp / "watch.err").open("wb") as stderr:
            return subprocess.Popen(
                [*TRIMD, "watch", "--link", f"mavlink:udpin:127.0.0.1:{port}?ids=vehicle",
                 "--profile", str(profile), "--headless", "--json", "--no-history",
                 *FAST_WATCH], stdout=stdout, stderr=stderr, cwd=REPO,
                env={**os.environ, "PYTHONPATH": str(REPO)})

    def records() -> list[dict[str, Any]]:
        return [json.loads(x) for x in out.read_text(encoding="utf-8").splitlines()
                if x.startswith("{") and x.endswith("}")]

    return (start, lambda: _first_alert(out)), records


def texts_from(tlog: Path, system: int, component: int) -> list[str]:
    """The STATUSTEXTs that reached MAVProxy from (system, component), in order."""
    return [m.text for _, m in TlogReader.open(tlog).messages()
            if m.get_type() == "STATUSTEXT"
            and (m.get_srcSystem(), m.get_srcComponent()) == (system, component)]


def sent_by(tlog: Path, system: int, component: int) -> dict[str, set[int]]:
    """What reached MAVProxy from (system, component): each message type with the commands
    (COMMAND_LONG) or types (HEARTBEAT) it carried."""
    kinds: dict[str, set[int]] = {}
    for _, msg in TlogReader.open(tlog).messages():
        if (msg.get_srcSystem(), msg.get_srcComponent()) == (system, component):
            kinds.setdefault(msg.get_type(), set()).add(
                int(getattr(msg, "command", getattr(msg, "type", 0))))
    return kinds
