"""Asked before quitting while the procedure runs: quitting aborts it first."""

from __future__ import annotations

from typing import ClassVar

from textual import on
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical
from textual.screen import ModalScreen
from textual.widgets import Button, Static

__all__ = ["QuitScreen"]


class QuitScreen(ModalScreen[bool]):
    """Dismissed with True to abort and quit, False to stay."""

    BINDINGS: ClassVar[list[BindingType]] = [Binding("y", "answer(True)", "Abort and quit"),
                Binding("n,escape", "answer(False)", "Stay")]

    def compose(self) -> ComposeResult:
        with Vertical(id="quit"):
            yield Static("The procedure is running.\nAbort it (trimd releases the vehicle) "
                         "and quit?")
            with Horizontal():
                yield Button("Abort and quit (y)", variant="error", id="yes")
                yield Button("Stay (n)", variant="primary", id="no")

    def action_answer(self, answer: bool) -> None:
        self.dismiss(answer)

    @on(Button.Pressed)
    def _pressed(self, event: Button.Pressed) -> None:
        self.dismiss(event.button.id == "yes")
