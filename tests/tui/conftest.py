"""The TUI tests' shared fixture: sessions over simulated time without wall-clock Ticks."""

from __future__ import annotations

import pytest

import trimd.app.session


@pytest.fixture()
def no_ticks(monkeypatch: pytest.MonkeyPatch) -> None:
    """No quiet-link Ticks from the wall clock: sample time alone, as in a replay. A
    FakeLink or in-process simulated vehicle has no wall clock of its own; with Ticks, an
    event loop starved for longer than the profile's ``link_timeout_s`` (a busy machine)
    ends the session as a lost link."""
    monkeypatch.setattr(trimd.app.session, "TICK_S", 1e6)
