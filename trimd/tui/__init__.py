"""The Textual terminal UI (issue 7): ``run_tui`` for ``trimd run`` / ``trimd demo``."""

from trimd.tui.app import TrimApp, make_app, run_tui

__all__ = ["TrimApp", "make_app", "run_tui"]
