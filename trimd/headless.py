"""Headless presenter: human progress lines, or one JSON object per line (``--json``)."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from typing import Any, TextIO

from trimd.cmd_solve import format_estimate
from trimd.estimate import StaticEstimate
from trimd.estimate_io import estimate_to_dict
from trimd.procedure import Notice, Output, Phase, Progress
from trimd.samples import Command, Health, HoldAttitude, Release, Sample, VehicleText

__all__ = ["HeadlessPresenter"]


class HeadlessPresenter:
    """Prints state changes, warnings, commands, a progress line every
    ``progress_every_s`` of sample time, and the final estimate and proposal.

    ``proposal_text`` / ``proposal_dict`` render the proposal (human / JSON); the stream
    defaults to the standard output of the moment of printing.
    """

    def __init__(self, stream: TextIO | None = None, *, json_lines: bool = False,
                 progress_every_s: float = 5.0,
                 proposal_text: Callable[[Any], str] = str,
                 proposal_dict: Callable[[Any], Any] = str) -> None:
        self.stream = stream
        self.json_lines = json_lines
        self.every = progress_every_s
        self.proposal_text = proposal_text
        self.proposal_dict = proposal_dict
        self._next_progress = -math.inf
        self._warned: set[str] = set()

    def _emit(self, text: str, obj: dict[str, Any]) -> None:
        line = json.dumps(obj) if self.json_lines else text
        print(line, file=self.stream or sys.stdout, flush=True)

    def output(self, out: Output, progress: Progress) -> None:
        t = out.t_s if isinstance(out, Notice) else progress.t_s
        if isinstance(out, Notice):
            if out.kind == "result":
                estimate, proposal = out.data
                self._result(estimate, proposal)
                return
            phase = out.data.value if isinstance(out.data, Phase) else None
            self._emit(f"[{t:8.1f} s] {out.kind + ': ' if out.kind != 'state' else ''}"
                       f"{out.text}", {"type": out.kind, "t_s": t, "phase": phase,
                                       "text": out.text})
        else:
            self._emit(f"[{t:8.1f} s] command: {_describe(out)}",
                       {"type": "command", "t_s": t, "command": _describe(out)})

    def sample(self, sample: Sample, progress: Progress) -> None:
        if isinstance(sample, Health):
            for warning in sample.warnings():
                if warning not in self._warned:
                    self._warned.add(warning)
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
        text = (f"[{p.t_s:8.1f} s]   hold {p.hold + 1}/{p.holds} {p.phase.value}: "
                f"settled {p.settled_fraction:4.0%}, {p.samples} samples, "
                f"{p.time_left_s:.0f} s left")
        self._emit(text, {"type": "progress", "t_s": p.t_s, "phase": p.phase.value,
                          "hold": p.hold + 1, "holds": p.holds,
                          "settled_fraction": p.settled_fraction, "samples": p.samples,
                          "time_left_s": p.time_left_s})

    def _result(self, estimate: StaticEstimate, proposal: Any) -> None:
        if self.json_lines:
            self._emit("", {"type": "result", "estimate": estimate_to_dict(estimate),
                            "proposal": None if proposal is None
                            else self.proposal_dict(proposal)})
            return
        text = format_estimate(estimate)
        if proposal is not None:
            text += "\n\n" + self.proposal_text(proposal)
        self._emit(text, {})


def _describe(command: Command) -> str:
    if isinstance(command, HoldAttitude):
        return (f"hold roll {math.degrees(command.phi):.1f}°, pitch "
                f"{math.degrees(command.theta):.1f}°, heading {math.degrees(command.psi):.1f}°")
    if isinstance(command, Release):
        return "release control"
    return repr(command)
