"""Headless presenter: human progress lines, or one JSON object per line (``--json``);
the confirmation prompt at a terminal, and the signals that stop a session."""

from __future__ import annotations

import asyncio
import math
import os
import signal
import sys
from collections.abc import Callable
from typing import Any, Protocol, TextIO

from trimd.app.jsonlines import print_json
from trimd.app.report import (
    NewCommands,
    NewWarnings,
    format_estimate,
    format_float,
    format_level_hold,
    format_proposal,
    format_verification,
)
from trimd.app.results import Finding
from trimd.ballast.proposal import Proposal, proposal_to_dict
from trimd.ballast.verify import Verification, verification_to_dict
from trimd.core.estimate import HoldSamples, StaticEstimate
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.events import Notice, Output, Phase, Progress
from trimd.core.floating import FloatResult, float_to_dict
from trimd.core.samples import Health, Sample, VehicleText

__all__ = ["STOP_SIGNALS", "HeadlessPresenter", "StdinConfirm", "result_to_dict",
           "stop_on_signals"]


def result_to_dict(estimate: StaticEstimate, proposal: Proposal | None) -> dict[str, Any]:
    """The ``result`` line: the estimate and the ballast proposal (null without one)."""
    return {"type": "result", "estimate": estimate_to_dict(estimate),
            "proposal": None if proposal is None else proposal_to_dict(proposal)}


class HeadlessPresenter:
    """Prints state changes, warnings, commands, a progress line every
    ``progress_every_s`` of sample time, and the final estimate and proposal.

    The stream defaults to the standard output of the moment of printing.
    """

    def __init__(self, stream: TextIO | None = None, *, json_lines: bool = False,
                 progress_every_s: float = 5.0) -> None:
        self.stream = stream
        self.json_lines = json_lines
        self.every = progress_every_s
        self._next_progress = -math.inf
        self._new_warnings = NewWarnings()
        self._new_commands = NewCommands()

    def _emit(self, text: str, obj: dict[str, Any]) -> None:
        if self.json_lines:
            print_json(obj, self.stream)
        else:
            print(text, file=self.stream or sys.stdout, flush=True)

    def output(self, out: Output[Proposal, Finding], progress: Progress) -> None:
        t = out.t_s if isinstance(out, Notice) else progress.t_s
        if isinstance(out, Notice):
            if out.result is not None:
                self.result(out.result.estimate, out.result.proposal)
                return
            if isinstance(out.verification, Verification):
                self._emit(format_verification(out.verification),
                           {"type": "verification", "t_s": t,
                            **verification_to_dict(out.verification)})
                return
            if isinstance(out.verification, FloatResult):
                self._emit(format_float(out.verification),
                           {"type": "float", "t_s": t, **float_to_dict(out.verification)})
                return
            if isinstance(out.verification, HoldSamples):
                h = out.verification
                self._emit(format_level_hold(h), {
                    "type": "level_hold", "t_s": t, "samples": len(h.t_s),
                    "t_start_s": float(h.t_s[0]), "t_end_s": float(h.t_s[-1]),
                    "tau_mean": [float(v) for v in h.tau.mean(axis=0)]})
                return
            phase = out.phase.value if out.phase is not None else None
            self._emit(f"[{t:8.1f} s] {out.kind + ': ' if out.kind != 'state' else ''}"
                       f"{out.text}", {"type": out.kind, "t_s": t, "phase": phase,
                                       "text": out.text})
        elif (text := self._new_commands(out)) is not None:
            self._emit(f"[{t:8.1f} s] command: {text}",
                       {"type": "command", "t_s": t, "command": text})

    def sample(self, sample: Sample, progress: Progress) -> None:
        if isinstance(sample, Health):
            for warning in self._new_warnings(sample):
                self._emit(f"[{sample.t_s:8.1f} s] warning: {warning}",
                           {"type": "warning", "t_s": sample.t_s, "text": warning})
        elif isinstance(sample, VehicleText):
            self._emit(f"[{sample.t_s:8.1f} s] vehicle {sample.level}: {sample.text}",
                       {"type": "vehicle", "t_s": sample.t_s, "severity": sample.severity,
                        "text": sample.text})
        if progress.phase not in (Phase.SETTLE, Phase.COLLECT) or sample.t_s < self._next_progress:
            return
        self._next_progress = sample.t_s + self.every
        p = progress
        what = f"hold {p.hold + 1}/{p.holds}" if p.setpoint_deg is not None else "float"
        text = (f"[{p.t_s:8.1f} s]   {what} {p.phase.value}: "
                f"settled {p.settled_fraction:4.0%}, {p.samples} samples, "
                f"{p.time_left_s:.0f} s left")
        self._emit(text, {"type": "progress", "t_s": p.t_s, "phase": p.phase.value,
                          "hold": p.hold + 1, "holds": p.holds,
                          "settled_fraction": p.settled_fraction, "samples": p.samples,
                          "time_left_s": p.time_left_s})

    def result(self, estimate: StaticEstimate, proposal: Proposal | None) -> None:
        """The estimate and the proposal: a ``result`` line, or their tables."""
        if self.json_lines:
            self._emit("", result_to_dict(estimate, proposal))
            return
        text = format_estimate(estimate)
        if proposal is not None:
            text += "\n\n" + format_proposal(proposal)
        self._emit(text, {})


#: Signals that stop a session cleanly: Ctrl-C (headless), ``kill``, an SSH drop.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class Operated(Protocol):
    """What the operator's answer goes to (a :class:`trimd.app.session.Session`)."""

    def confirm(self) -> None: ...

    def abort(self, reason: str = ...) -> None: ...


class StdinConfirm:
    """Headless confirmation at a terminal: ask once when the procedure is ready."""

    def __init__(self, session: Operated) -> None:
        self.session = session

    def output(self, out: Output[object, object], progress: Progress) -> None:
        if isinstance(out, Notice) and out.phase is Phase.CONFIRM:
            asyncio.get_running_loop().create_task(self._ask())

    def sample(self, sample: Sample, progress: Progress) -> None:
        return None

    async def _ask(self) -> None:
        print("type 'yes' to let trimd command the vehicle, anything else aborts: ",
              end="", file=sys.stderr, flush=True)
        answer = await _read_line(sys.stdin.fileno())
        if answer.strip().lower() == "yes":
            self.session.confirm()
        else:
            self.session.abort("not confirmed by the operator")


async def _read_line(fd: int) -> str:
    """One line from ``fd`` ("" at end of file) without a thread: a blocked ``input()``
    in an executor would keep the process alive after a signal ended the session."""
    loop = asyncio.get_running_loop()
    line: asyncio.Future[str] = loop.create_future()
    buffer = bytearray()

    def readable() -> None:
        chunk = os.read(fd, 1024)
        buffer.extend(chunk)
        if (not chunk or b"\n" in chunk) and not line.done():
            line.set_result(buffer.split(b"\n", 1)[0].decode(errors="replace"))

    loop.add_reader(fd, readable)
    try:
        return await line
    finally:
        loop.remove_reader(fd)


def stop_on_signals(stop: Callable[[str], None]) -> None:
    """On any of :data:`STOP_SIGNALS`, call ``stop("stopped by SIGTERM")`` (etc.) on the
    running loop: ``Session.abort`` headless, ``TrimApp.stop`` in the TUI. Either way the
    session releases the vehicle and closes the log before the process exits."""
    loop = asyncio.get_running_loop()
    for sig in STOP_SIGNALS:
        loop.add_signal_handler(sig, stop, f"stopped by {sig.name}")
