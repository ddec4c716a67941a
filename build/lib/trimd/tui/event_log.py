"""Messages panel: state changes, warnings, commands and events, stamped with session
time (the samples' time base, so a replay shows the same stamps)."""

from __future__ import annotations

import math

from rich.text import Text
from textual.widgets import RichLog

__all__ = ["EventLog"]

_STYLES = {"state": "bold", "info": "", "warning": "bold yellow", "result": "bold green",
           "command": "cyan", "error": "bold red"}


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
