"""``trimd run``'s exit code for each way a session ends (docs/operator.md)."""

from __future__ import annotations

import pytest

from trimd.app.session import SessionResult
from trimd.cli.run import _exit_code
from trimd.core.events import Cause, Phase

CASES = [
    (Phase.DONE, Cause.NONE, 0),
    (Phase.FAILED, Cause.PILOT, 1),        # the pilot took over: not a link error
    (Phase.FAILED, Cause.VEHICLE, 1),      # disarmed mid-hold
    (Phase.FAILED, Cause.ENVELOPE, 1),
    (Phase.FAILED, Cause.TIMEOUT, 1),
    (Phase.FAILED, Cause.ESTIMATION, 1),
    (Phase.FAILED, Cause.INTERNAL, 1),
    (Phase.ABORTED, Cause.OPERATOR, 1),
    (Phase.FAILED, Cause.LINK, 3),         # lost, never connected, another protocol version
]


@pytest.mark.parametrize(("phase", "cause", "code"), CASES)
def test_each_end_of_a_session_has_its_exit_code(phase: Phase, cause: Cause, code: int) -> None:
    assert _exit_code(SessionResult(phase, "why", cause, None, None, None)) == code


def test_every_cause_has_a_case_above() -> None:
    assert {cause for _, cause, _ in CASES} == set(Cause)
