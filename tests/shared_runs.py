"""Runs that several tests make alike, made once per test run and handed to each as a copy
of its own.

A simulated trim, verify hold or float is a function of its arguments alone (the
simulator's time, a seed: ``tests/app/test_run_sim.py``'s reproducibility test makes the
same trim twice, unshared), and several modules check different things of the same few
trims of the perturbed Heavy. Under pytest-xdist they run in different worker processes,
so the first worker to ask for a run makes it and leaves it, pickled, in the test run's
temporary folder; another that asks meanwhile waits for it (a lock file per run), one
that asks later reads it. Every caller gets a fresh unpickled copy: a test that steps the
returned simulator or changes the result changes nothing another test sees.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import ParamSpec, TypeVar

P = ParamSpec("P")
T = TypeVar("T")

#: The folder the runs are kept in, shared by the test run's workers (``tests/conftest.py``
#: sets it); None (the benchmarks): every run is made afresh.
DIRECTORY: Path | None = None


def shared_run(make: Callable[P, T]) -> Callable[P, T]:
    """``make`` shared: called once per test run for the same arguments (pickled: two
    profiles that differ in any field are different arguments), each caller getting a copy
    of the result. A call with a callable argument is not shared; ``.__wrapped__`` is
    ``make`` itself, afresh every time."""
    @functools.wraps(make)
    def run(*args: P.args, **kwargs: P.kwargs) -> T:
        if DIRECTORY is None or any(callable(a) for a in (*args, *kwargs.values())):
            return make(*args, **kwargs)
        key = hashlib.sha256(pickle.dumps((make.__qualname__, args, sorted(kwargs.items())))
                             ).hexdigest()[:32]
        value: T = pickle.loads(_made_once(DIRECTORY, key, lambda: make(*args, **kwargs)))
        return value
    return run


def _made_once(directory: Path, key: str, make: Callable[[], object]) -> bytes:
    """The pickled run ``key``: read from ``directory``, or made by ``make()`` and left
    there (under the run's lock, so that two workers never make the same run)."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{key}.pickle"
    with open(directory / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)          # released when the file closes
        if path.exists():
            return path.read_bytes()
        data = pickle.dumps(make())
        partial = path.with_suffix(f".{os.getpid()}")
        partial.write_bytes(data)
        partial.replace(path)                     # whole or absent, never half-written
        return data
