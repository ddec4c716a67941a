"""Pacing a served simulator against the wall clock (real time, or ``rate`` times faster).

A server hands :func:`run_paced` its ``advance_to`` (handle input, step the vehicle to a
simulated time, send what is due) and the descriptors its input arrives on; between steps
the loop sleeps in ``select`` so that input wakes it at once.
"""

from __future__ import annotations

import math
import select
import threading
import time
from collections.abc import Callable, Sequence

from trimd.drivers.sim.vehicle import SimVehicle

__all__ = ["run_paced"]

#: Longest sleep between two looks at ``stop`` [s, wall clock].
MAX_SLEEP_S = 0.1


def run_paced(vehicle: SimVehicle, advance_to: Callable[[float], None],
              fd: int | Sequence[int], *,
              rate: float, stop: threading.Event | None = None,
              duration_s: float = math.inf) -> None:
    """Advance ``vehicle`` through ``advance_to`` at ``rate`` simulated seconds per wall
    second until ``stop`` is set or ``duration_s`` [s] of simulated time has passed."""
    if not rate > 0:
        raise ValueError(f"rate must be positive, got {rate}")
    t_wall0, t_sim0 = time.monotonic(), vehicle.t_s
    while not (stop is not None and stop.is_set()) and vehicle.t_s - t_sim0 < duration_s:
        advance_to(t_sim0 + (time.monotonic() - t_wall0) * rate)
        wait = t_wall0 + (vehicle.t_s + vehicle.dt_s - t_sim0) / rate - time.monotonic()
        if wait > 0:
            select.select([fd] if isinstance(fd, int) else fd, [], [], min(wait, MAX_SLEEP_S))
