"""The Textual terminal UI (issue 7): ``make_app`` for ``trimd run`` / ``demo`` / ``replay``."""

from trimd.tui.app import TrimApp, make_app

__all__ = ["TrimApp", "make_app"]
