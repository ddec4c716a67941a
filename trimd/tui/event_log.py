"""Messages panel: state changes, warnings, commands and events, stamped with session
time (the samples' time base, so a replay shows the same stamps)."""

from __future__ import annotations

import math

from rich.text import Text
from textual.widgets import RichLog

from trimd.samples import Command, HoldAttitude, Release

__all__ = ["EventLog", "describe_command"]

_STYLES = {"state": "bold", "info": "", "warning": "bold yellow", "result": "bold green",
           "command": "cyan", "error": "bold red"}


def describe_command(command: Command) -> str:
    """A short description of a command for the log."""
    if isinstance(command, HoldAttitude):
        return (f"hold roll {math.degrees(command.phi):.1f}°, pitch "
                f"{math.degrees(command.theta):.1f}°, yaw {math.degrees(command.psi):.1f}°")
    if isinstance(command, Release):
        return "release control"
    return repr(command)


class EventLog(RichLog):
    """Every entry is also kept in ``entries`` (sample time, kind, text) for the report."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id, wrap=True, min_width=20, max_lines=1000, markup=False)
        self.entries: list[tuple[float, str, str]] = []
        self.border_title = "Messages"

    def add(self, t_s: float, kind: str, text: str) -> None:
        """Append one entry: ``kind`` is state, info, warning, result, command or error."""
        self.entries.append((t_s, kind, text))
        stamp = "     —" if math.isnan(t_s) else f"{t_s:6.1f}"
        line = Text(f"{stamp} ", style="dim")
        line.append(text, style=_STYLES.get(kind, ""))
        self.write(line)
