"""Keep the MILP solver's native output off trimd's standard output.

scipy's ``milp`` runs HiGHS, which now and then prints a debug line from C straight to
file descriptor 1 whatever its display options ("HighsMipSolverData::
transformNewIntegerFeasibleSolution tmpSolver.run();", HiGHS issue 2783): on a hard
search it would land between the JSON lines of ``trimd run --json`` or the headless
progress. :func:`solver_stdout_to_log` points descriptor 1 at a temporary file for the
length of a solve and logs what came, at debug level. A solve runs in the session's own
thread, which is the only one that writes to standard output (the terminal UI draws on
standard error).
"""

from __future__ import annotations

import logging
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["solver_stdout_to_log"]

log = logging.getLogger(__name__)


@contextmanager
def solver_stdout_to_log() -> Iterator[None]:
    """While it lasts, what native code writes to descriptor 1 goes to the debug log."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 1)
            try:
                yield
            finally:
                os.dup2(saved, 1)
                sink.seek(0)
                printed = sink.read().decode("utf-8", "replace").strip()
                if printed:
                    log.debug("the MILP solver printed: %s", printed)
    finally:
        os.close(saved)
