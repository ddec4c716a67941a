"""Help screen: the keys (from the app's bindings, so it cannot drift) and the panels."""

from __future__ import annotations

from typing import ClassVar

from rich.table import Table
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Static

__all__ = ["HelpScreen"]

PANELS = (
    ("Link", "transport, vehicle, mode, armed, message rates [Hz], bad frames, time since "
             "the last heartbeat (red when stale)"),
    ("Procedure", "the steps (✓ done, ▶ now, ✗ stopped), settle and collect progress, time "
                  "left before the step times out, the reason when it ends"),
    ("Attitude", "roll, pitch, yaw and depth → their set-points; roll and pitch over the "
                 "last minute (dim lines: set-points)"),
    ("Thrusters", "effort = thrust / the most available that way; red: saturated"),
    ("Result", "weight, extra mass, centre of gravity ± 1σ; top view (▲ forward, ⊗ "
               "thrusters, lettered slots: yellow weights, cyan floats; CG0 → CG1 magnified); "
               "passive trim and net buoyancy after ballasting"),
    ("Next steps", "after a trim with a proposal: p records the milp proposal as installed "
                   "(trimd ballast apply), then, with the ballast fitted, y runs a verify hold"),
    ("Verdict", "the verify hold: residual trim measured vs predicted, the quantities that "
                "differ in red"),
    ("Messages", "events, warnings and commands, stamped with session time"),
)


class HelpScreen(ModalScreen[None]):
    """Lists ``bindings``; any of escape, q, ? or F1 closes it."""

    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape,q,question_mark,f1", "dismiss", "Close")]

    def __init__(self, bindings: list[Binding]) -> None:
        super().__init__()
        self.keys = bindings

    def compose(self) -> ComposeResult:
        keys = Table.grid(padding=(0, 2))
        for b in self.keys:
            keys.add_row(f"[bold]{b.key_display or b.key}[/]", b.description)
        panels = Table.grid(padding=(0, 2))
        for name, what in PANELS:
            panels.add_row(f"[bold]{name}[/]", what)
        with VerticalScroll(id="help"):
            yield Static("[b]Keys[/b]  (ctrl+p: command palette)")
            yield Static(keys)
            yield Static("\n[b]Panels[/b]")
            yield Static(panels)
