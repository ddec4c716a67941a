"""What the TUI shows of the live link: latest samples, set-points, rates and a minute of
roll and pitch history. Plain state updated by the presenter on every sample (cheap), read by
the panels when they refresh (at most at the terminal's pace).

Rates and the history are on the samples' own time base; only the age of the last
heartbeat uses the ``clock`` (the monotonic clock by default): a dead link sends no
samples, so sample time cannot tell how long it has been silent.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from trimd.core.samples import (
    Attitude,
    Battery,
    Command,
    Depth,
    Health,
    HoldAttitude,
    Release,
    Sample,
    Thrusters,
)

__all__ = ["HISTORY_S", "LiveState", "Point", "Setpoint"]

#: Length of the attitude history [s of sample time].
HISTORY_S = 60.0
#: One history point per this much sample time [s] (300 points a minute).
_HISTORY_STEP_S = 0.2
#: Rates are counted over this window of sample time [s].
_RATE_WINDOW_S = 5.0
_STREAMS: dict[type, str] = {Attitude: "att", Thrusters: "thr", Depth: "depth",
                             Health: "hb", Battery: "batt"}


@dataclass(frozen=True, slots=True)
class Point:
    """One history point: sample time [s], roll and pitch [deg], depth [m] (NaN: none
    yet)."""

    t_s: float
    roll_deg: float
    pitch_deg: float
    depth_m: float = math.nan


@dataclass(frozen=True, slots=True)
class Setpoint:
    """The hold being commanded: roll, pitch, yaw [deg] and the depth held [m]."""

    roll_deg: float
    pitch_deg: float
    yaw_deg: float
    depth_m: float


class LiveState:
    """Latest samples, the commanded set-point, per-stream rates and the history."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.restart()

    def restart(self) -> None:
        """Forget everything (a new session: its time starts again at 0)."""
        self.attitude: Attitude | None = None
        self.depth: Depth | None = None
        self.thrusters: Thrusters | None = None
        self.battery: Battery | None = None
        self.health: Health | None = None
        self.setpoint: Setpoint | None = None
        self.history: deque[Point] = deque()
        self.t_s = math.nan
        self._heartbeat_at: float | None = None
        self._arrivals: dict[str, deque[float]] = {k: deque() for k in _STREAMS.values()}

    def sample(self, s: Sample) -> None:
        """Take one sample (session time)."""
        self.t_s = s.t_s
        stream = _STREAMS.get(type(s))
        if stream is not None:
            times = self._arrivals[stream]
            times.append(s.t_s)
            while times and times[0] <= s.t_s - _RATE_WINDOW_S:
                times.popleft()
        if isinstance(s, Attitude):
            self.attitude = s
            self._remember(s)
        elif isinstance(s, Depth):
            self.depth = s
        elif isinstance(s, Thrusters):
            self.thrusters = s
        elif isinstance(s, Battery):
            self.battery = s
        elif isinstance(s, Health):
            self.health = s
            if s.connected:
                self._heartbeat_at = self.clock()

    def command(self, command: Command) -> None:
        """A command was sent: a hold sets the set-point (depth: held where it is now)."""
        if isinstance(command, HoldAttitude):
            depth = self.depth.depth_m if self.depth else math.nan
            self.setpoint = Setpoint(math.degrees(command.phi), math.degrees(command.theta),
                                     math.degrees(command.psi), depth)
        elif isinstance(command, Release):
            self.setpoint = None

    def rate_hz(self, stream: str) -> float:
        """Messages per second of ``stream`` (att, thr, depth, hb, batt) lately."""
        times = self._arrivals[stream]
        recent = [t for t in times if t > self.t_s - _RATE_WINDOW_S]
        return len(recent) / _RATE_WINDOW_S

    def heartbeat_age_s(self) -> float | None:
        """Seconds since the last heartbeat on ``clock``; None before the first."""
        return None if self._heartbeat_at is None else self.clock() - self._heartbeat_at

    def _remember(self, a: Attitude) -> None:
        if self.history and a.t_s - self.history[-1].t_s < _HISTORY_STEP_S:
            return
        self.history.append(Point(a.t_s, math.degrees(a.phi), math.degrees(a.theta),
                                  self.depth.depth_m if self.depth else math.nan))
        while self.history[0].t_s < a.t_s - HISTORY_S:
            self.history.popleft()
