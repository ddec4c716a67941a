"""The MILP solver's native prints stay off standard output (HiGHS writes a debug line to
descriptor 1 now and then, whatever its options), and go to the debug log."""

from __future__ import annotations

import logging
import os

import pytest

from trimd.ballast.highs import solver_stdout_to_log


def test_native_output_during_a_solve_goes_to_the_log(
        capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture) -> None:
    """What Python printed before stays on standard output, in order; what native code
    writes to descriptor 1 during the solve is logged; afterwards descriptor 1 is standard
    output again."""
    caplog.set_level(logging.DEBUG, logger="trimd.ballast.highs")
    print("before")
    with solver_stdout_to_log():
        os.write(1, b"HighsMipSolverData::transformNewIntegerFeasibleSolution\n")
    os.write(1, b"after\n")
    assert capfd.readouterr().out == "before\nafter\n"
    printed = "HighsMipSolverData::transformNewIntegerFeasibleSolution"
    assert [r.getMessage() for r in caplog.records] == [f"the MILP solver printed: {printed}"]


def test_standard_output_comes_back_when_the_solve_fails(
        capfd: pytest.CaptureFixture[str]) -> None:
    """An exception in the solve leaves descriptor 1 as it was."""
    with pytest.raises(ValueError), solver_stdout_to_log():
        raise ValueError("infeasible")
    os.write(1, b"still here\n")
    assert capfd.readouterr().out == "still here\n"
