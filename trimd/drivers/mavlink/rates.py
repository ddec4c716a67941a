"""The telemetry rates the vehicle actually sends, measured on the vehicle's own clock.

ArduPilot applies the last rate request it received, whoever sent it: a ground station
beside trimd (QGroundControl, MAVProxy: REQUEST_DATA_STREAM at 4 Hz every 15 s) lowers
what trimd asked for. :class:`RateWatch` counts each watched message over the last
:data:`WINDOW_S` of vehicle time (``time_boot_ms``, so a simulator running faster than
real time and network jitter do not matter) and names those that fall below
:data:`LOW_FRACTION` of the rate asked, or that have been silent for :data:`GAP_PERIODS`
periods (at least :data:`GAP_MIN_S`: a drop to 1 Hz or less is noticed long before a
window's average shows it, and before the procedure's stream timeout); the commander then
asks again.
"""

from __future__ import annotations

import math
from collections import deque

from trimd.drivers.mavlink.message import MavMessage

__all__ = ["GAP_MIN_S", "GAP_PERIODS", "LOW_FRACTION", "WINDOW_S", "RateWatch"]

#: Rates are judged over this much vehicle time [s], starting once a request took effect.
WINDOW_S = 5.0
#: A rate below this fraction of the rate asked is too low.
LOW_FRACTION = 0.7
#: A message silent for this many of its periods (asked) is too slow, at once …
GAP_PERIODS = 3.0
#: … but never for less than this [s] of vehicle time.
GAP_MIN_S = 0.5
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

    def note(self, msg: MavMessage) -> None:
        """One message from the vehicle."""
        t_boot = getattr(msg, "time_boot_ms", None)
        if t_boot is not None:
            t = int(t_boot) / 1000
            if t < self.t_vehicle - _REBOOT_S:
                for name in self._times:
                    self._times[name].clear()
                    self._since[name] = t
                self.t_vehicle = t
            elif not t <= self.t_vehicle:  # also the first time (NaN)
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
        """(message, received rate [Hz]) of those too slow: below :data:`LOW_FRACTION`
        of the rate asked over the window, or silent for too long (rate: 1 / silence)."""
        out = []
        for name, hz in self.asked.items():
            got = self.rate(name)
            times = self._times[name]
            last = max(times[-1] if times else -math.inf, self._since[name])
            silence = self.t_vehicle - last
            if got is not None and got < LOW_FRACTION * hz:
                out.append((name, got))
            elif silence > max(GAP_PERIODS / hz, GAP_MIN_S):
                out.append((name, 1 / silence))
        return out
