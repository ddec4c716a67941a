"""Procedure panel: the steps with the current one highlighted, settle and collect
progress bars, time left before the step times out, and the reason when it ends. A verify
hold has one hold (the level one) and ends in the verdict instead of a proposal; a float
check lets go of the vehicle and ends in the attitude it floats at."""

from __future__ import annotations

import math
from collections.abc import Sequence

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

from trimd.core.events import Phase, Progress
from trimd.core.profile import HoldSetpoint, Profile

__all__ = ["Stepper", "bar"]

_DONE, _NOW, _TODO, _FAIL = ("✓", "green"), ("▶", "bold yellow"), ("·", "dim"), ("✗", "bold red")
_PRE = (Phase.CONNECT, Phase.PRECHECK, Phase.CONFIRM)


def bar(fraction: float, width: int, style: str = "green") -> Text:
    """A progress bar of ``width`` cells (eighths of a cell resolution)."""
    f = min(1.0, max(0.0, fraction)) if math.isfinite(fraction) else 0.0
    eighths = round(f * width * 8)
    full, part = divmod(eighths, 8)
    text = Text("█" * full + ("▏▎▍▌▋▊▉"[part - 1] if part else ""), style=style)
    text.append("·" * (width - len(text)), style="dim")
    return text


def _step(progress: Progress) -> int:
    """Index of the active step: connect, precheck, confirm, the holds, solve."""
    if progress.phase in _PRE:
        return _PRE.index(progress.phase)
    if progress.phase in (Phase.SETTLE, Phase.COLLECT):
        return len(_PRE) + progress.hold
    return len(_PRE) + progress.holds + 1


def _hold_steps(holds: Sequence[HoldSetpoint]) -> list[str]:
    """One step per hold: its number and attitude."""
    return [f"hold {k + 1}/{len(holds)}  roll {h.roll_deg:g}° pitch {h.pitch_deg:g}°"
            for k, h in enumerate(holds)]


class Stepper(Widget):
    """Redrawn whenever ``progress`` changes."""

    progress: reactive[Progress | None] = reactive(None)

    def __init__(self, profile: Profile, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.profile = profile
        self.border_title = "Procedure"
        self.steps = _hold_steps(profile.holds)
        self.last_step = "solve → proposal"
        self._active = 0
        self._shape: tuple[int, Phase | None] = (0, None)

    def restart(self, kind: str) -> None:
        """A new session: ``kind`` "verify" (one level hold, then the verdict), "float"
        (thrusters at neutral, then the attitude it floats at) or "trim"."""
        self.steps = (["float: thrusters at neutral"] if kind == "float" else
                      _hold_steps(self.profile.holds[:1] if kind == "verify"
                                  else self.profile.holds))
        self.last_step = {"verify": "compare → verdict",
                          "float": "settled → floats at"}.get(kind, "solve → proposal")
        self.border_title = {"verify": "Verify hold", "float": "Float check"}.get(
            kind, "Procedure")
        self._active = 0
        self.progress = None
        self.refresh(layout=True)

    def watch_progress(self, progress: Progress | None) -> None:
        if progress is not None and not progress.phase.final:
            self._active = _step(progress)
        shape = (self._active, None if progress is None else progress.phase)
        if shape != self._shape:  # lines come and go: measure the height again
            self._shape = shape
            self.refresh(layout=True)
        self.set_class(progress is not None and progress.phase in (Phase.FAILED, Phase.ABORTED),
                       "-failed")
        self.set_class(progress is not None and progress.phase is Phase.DONE, "-done")

    def _mark(self, index: int) -> tuple[str, str]:
        p = self.progress
        if p is None:
            return _NOW if index == 0 else _TODO
        if p.phase is Phase.DONE or index < self._active:
            return _DONE
        if index == self._active:
            return _FAIL if p.phase.final else _NOW
        return _TODO

    def render(self) -> Text:
        p, width = self.progress, self.content_size.width
        text = Text()
        for i, phase in enumerate(_PRE):
            mark, style = self._mark(i)
            text.append(f"{mark} {phase.value}  ", style=style)
        text.append("\n")
        for k, step in enumerate(self.steps):
            mark, style = self._mark(len(_PRE) + k)
            text.append(f"{mark} {step}\n", style=style)
            if p is not None and self._active == len(_PRE) + k and not p.phase.final:
                text.append_text(self._bars(p, width))
        mark, style = self._mark(len(_PRE) + len(self.steps))
        text.append(f"{mark} {self.last_step}\n", style=style)
        if p is not None:
            status = "bold red" if p.phase in (Phase.FAILED, Phase.ABORTED) else (
                "bold green" if p.phase is Phase.DONE else "")
            text.append(p.phase.value.upper(), style=status or "bold")
            text.append(f": {p.message}" if p.message else "", style=status)
            if math.isfinite(p.time_left_s) and not p.phase.final:
                text.append(f"  ({max(0.0, p.time_left_s):.0f} s left)")
        return text

    def _bars(self, p: Progress, width: int) -> Text:
        w = max(4, width - 24)
        text = Text("  settle  ")
        text.append_text(bar(p.settled_fraction, w))
        text.append(f" {p.settled_fraction:4.0%}\n")
        text.append("  collect ")
        collected = 0.0
        if p.phase is Phase.COLLECT:
            collected = 1.0 - p.time_left_s / self.profile.procedure.collect_max_s
        text.append_text(bar(collected, w, "cyan"))
        text.append(f" {p.samples:4d} smp\n")
        return text
