"""The telemetry rates the vehicle actually sends, measured on the vehicle's own clock.

ArduPilot applies the last rate request it received, whoever sent it: a ground station
beside trimd (QGroundControl, MAVProxy: REQUEST_DATA_STREAM at 4 Hz every 15 s) lowers
what trimd asked for. :class:`RateWatch` counts each watched message over the last
:data:`WINDOW_S` of vehicle time (``time_boot_ms``, so a simulator running faster than
real time and network jitter do not matter) and names those that fall below
:data:`LOW_FRACTION` of the rate asked; the commander then asks again.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

__all__ = ["LOW_FRACTION", "WINDOW_S", "RateWatch"]

#: Rates are judged over this much vehicle time [s], starting once a request took effect.
WINDOW_S = 5.0
#: A rate below this fraction of the rate asked is too low.
LOW_FRACTION = 0.7
_REBOOT_S = 1.0             # the vehicle clock going back this far: a reboot, start over


class RateWatch:
    """Received rates [Hz] of the messages trimd asked for, on the vehicle's clock."""

    def __init__(self) -> None:
        self.asked: dict[str, float] = {}           # message → rate asked [Hz]
        self.t_vehicle = math.nan                   # latest time_boot_ms seen [s]
        self._since: dict[str, float] = {}          # vehicle time each request took effect
        self._times: dict[str, deque[float]] = {}

    def asked_for(self, name: str, hz: float) -> None:
        """trimd's request for ``name`` at ``hz`` was accepted (judged a window later)."""
        self.asked[name] = hz
        self._since[name] = self.t_vehicle
        self._times[name] = deque()

    def forget(self, name: str) -> None:
        """Stop judging ``name`` (asked again: judged once that is accepted)."""
        self.asked.pop(name, None)

    def note(self, msg: Any) -> None:
        """One message from the vehicle."""
        t_boot = getattr(msg, "time_boot_ms", None)
        if t_boot is not None:
            t = int(t_boot) / 1000
            if t < self.t_vehicle - _REBOOT_S:
                for name in self._times:
                    self._times[name].clear()
                    self._since[name] = t
            if not t <= self.t_vehicle:
                self.t_vehicle = t
        times = self._times.get(msg.get_type())
        if times is not None and math.isfinite(self.t_vehicle):
            times.append(self.t_vehicle)
            while times and times[0] <= self.t_vehicle - WINDOW_S:
                times.popleft()

    def rate(self, name: str) -> float | None:
        """Received rate of ``name`` [Hz] over the last window; None until a whole window
        has passed since the request took effect."""
        since = self._since.get(name, math.nan)
        if math.isnan(since):  # asked before the vehicle clock was known
            since = self._since[name] = self.t_vehicle
        if name not in self.asked or not self.t_vehicle - since >= WINDOW_S:
            return None
        return len(self._times[name]) / WINDOW_S

    def low(self) -> list[tuple[str, float]]:
        """(message, received rate [Hz]) of those below :data:`LOW_FRACTION` of the rate
        asked."""
        out = []
        for name, hz in self.asked.items():
            got = self.rate(name)
            if got is not None and got < LOW_FRACTION * hz:
                out.append((name, got))
        return out
