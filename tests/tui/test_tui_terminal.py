"""``trimd run`` / ``trimd demo`` in the TUI as a process on a pseudo-terminal: SIGTERM
and SIGHUP release the vehicle and close the log; after the operator
quits, the estimate and proposal are printed as the headless daemon prints them."""

from __future__ import annotations

import os
import pty
import re
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.helpers import PROFILES, REPO
from tests.tui.tui_helpers import HANG_GUARD_S

#: A hold that never settles (it must be steady longer than it may take): the session
#: stays in hold 1 until something stops it, however fast the simulator runs.
NEVER_SETTLES = {"min_steady_s: 10.0": "min_steady_s: 1000000.0",
                 "settle_timeout_s: 180.0": "settle_timeout_s: 10000000.0"}


class Terminal:
    """``trimd ARGS`` on a pseudo-terminal of 80×24; everything it writes is kept."""

    def __init__(self, *args: str) -> None:
        pid, self.fd = pty.fork()
        if pid == 0:  # the child: the pty is its controlling terminal
            os.chdir(REPO)
            os.environ.update(TERM="xterm-256color", COLUMNS="80", LINES="24")
            os.execv(sys.executable, [sys.executable, "-m", "trimd", *args])
        self.pid = pid
        self.output = bytearray()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        """Drain the terminal (a full pty would block the app) until it closes."""
        while True:
            try:
                data = os.read(self.fd, 65536)
            except OSError:
                return
            if not data:
                return
            self.output += data

    def wait_for(self, cond: Callable[[], bool]) -> None:
        """Wait until ``cond()`` holds while trimd runs; fail if it exits first, or past
        the hang guard (nothing is timed)."""
        hung_at = time.monotonic() + HANG_GUARD_S
        while not cond():
            assert self._reader.is_alive(), f"trimd ended first:\n{self.text[-2000:]}"
            if time.monotonic() > hung_at:
                pytest.fail(f"hang guard: nothing happened within {HANG_GUARD_S:g} s")
            time.sleep(0.1)

    def type(self, keys: str) -> None:
        os.write(self.fd, keys.encode())

    def hang_up(self) -> None:
        """Close the terminal, as an SSH drop does: the kernel sends SIGHUP to trimd."""
        os.close(self.fd)
        self.fd = -1

    def wait(self) -> int:
        """The exit code (a death by signal: 128 + its number, as a shell reports it)."""
        status: list[int] = []
        waiter = threading.Thread(target=lambda: status.append(os.waitpid(self.pid, 0)[1]),
                                  daemon=True)
        waiter.start()
        waiter.join(timeout=HANG_GUARD_S)
        if not status:
            os.kill(self.pid, signal.SIGKILL)
            pytest.fail(f"hang guard: trimd did not exit within {HANG_GUARD_S:g} s")
        self._reader.join(timeout=HANG_GUARD_S)
        if self.fd >= 0:
            os.close(self.fd)
        code = os.waitstatus_to_exitcode(status[0])
        return 128 - code if code < 0 else code

    @property
    def text(self) -> str:
        """What was written, without the terminal's control sequences."""
        raw = self.output.decode("utf-8", "replace")
        return re.sub(r"\x1b(\[[0-?]*[ -/]*[@-~]|\][^\x07\x1b]*(\x07|\x1b\\)|[()][0-9A-Za-z]|.)",
                      "", raw)


def log_has(path: Path, text: str) -> Callable[[], bool]:
    """``text`` is in the session log (flushed at least once a second)."""
    return lambda: path.exists() and text.encode() in path.read_bytes()


@pytest.mark.parametrize("how", ["SIGTERM", "SIGHUP"])
def test_a_signal_mid_hold_releases_and_closes_the_log(tmp_path: Path, how: str) -> None:
    """SIGTERM, SIGHUP, and a terminal that really goes away (then Textual could never
    restore it: trimd must still exit, not hang)."""
    profile = (PROFILES / "sabertooth-dh2.yaml").read_text()
    for old, new in NEVER_SETTLES.items():
        assert old in profile
        profile = profile.replace(old, new)
    (tmp_path / "stuck.yaml").write_text(profile)
    log = tmp_path / "session.tlog"
    term = Terminal("run", "--link", "sim:payload=10@AftSB", "--profile",
                    str(tmp_path / "stuck.yaml"), "--yes", "--record", str(log))
    term.wait_for(log_has(log, "hold 1/2"))  # commanding the vehicle: it must be released
    if how == "hang-up":
        term.hang_up()
    else:
        os.kill(term.pid, getattr(signal, how))
    assert term.wait() == 1  # aborted: not 143 / 129 (killed by the signal)
    data = log.read_bytes()
    signame = "SIGHUP" if how == "hang-up" else how
    assert b"trimd: release control" in data and f"stopped by {signame}".encode() in data
    if how == "SIGTERM":  # the terminal is still there to tell why
        assert f"trimd: aborted: stopped by {how}" in term.text


@pytest.mark.slow
def test_demo_prints_the_result_after_the_tui_quits(tmp_path: Path) -> None:
    log = tmp_path / "demo.tlog"
    term = Terminal("demo", "--record", str(log))
    term.wait_for(log_has(log, "trimd: release control"))  # done: the session ended
    term.type("q")  # quits at once once the session has ended; else asks first:
    term.type("y")  # quitting a session that has ended aborts nothing
    assert term.wait() == 0
    out = term.text
    assert "extra mass m_ext" in out and "ballast by milp" in out
    assert "simulator truth: payload 10@AftSB" in out
    assert f"session log: {log}" in out
