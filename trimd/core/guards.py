"""The safety rules of every state machine that commands the vehicle (the trim procedure,
the excitation experiment), in one place so they cannot drift apart.

Before commanding, the vehicle must be connected. While commanding it must stay
connected and armed, within the attitude envelope (the profile's ``max_tilt_deg`` plus
:data:`ENVELOPE_MARGIN_DEG`) and the depth envelope (``max_depth_excursion_m``, or the
experiment's own limit, from a reference depth), nobody else may fly it (a
:class:`PilotInput`), and telemetry must keep arriving: no sample at all for
``link_timeout_s`` of sample time is a lost link; a stream it is steered by that stops
while others go on is lost after ``link_timeout_s`` or :data:`STREAM_MISSED_PERIODS`
periods at the slowest rate it may arrive at, whichever is longer (a 1 Hz depth stream
is not lost after 0.8 s). Any breach is a :class:`Stop`, on which the state machine
releases the vehicle and ends. Pure: time is the samples' own.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from trimd.core.events import Cause
from trimd.core.profile import ProcedureLimits
from trimd.core.samples import Attitude, Depth, Health, PilotInput, Sample, Thrusters

__all__ = ["ENVELOPE_MARGIN_DEG", "STREAMS", "STREAM_MISSED_PERIODS", "Guard", "Stop"]

#: An attitude beyond the profile's tilt limit by this much [deg] ends the commanding.
ENVELOPE_MARGIN_DEG = 5.0
#: The telemetry streams a commanding state machine relies on, by sample type.
STREAMS: dict[str, type[Sample]] = {"attitude": Attitude, "thrusters": Thrusters,
                                    "depth": Depth}
#: A stream that stops while others go on is lost after this many of its periods (at the
#: slowest rate it may arrive at), if that is longer than ``link_timeout_s``.
STREAM_MISSED_PERIODS = 2.5


@dataclass(frozen=True, slots=True)
class Stop:
    """A breached rule: release the vehicle and end, saying ``reason``."""

    reason: str
    cause: Cause


class Guard:
    """Watches every sample and the clock for a reason to stop commanding.

    Parameters
    ----------
    limits : the profile's procedure limits (tilt, depth excursion, link timeout).
    depth_excursion_m : the depth envelope [m] (default: the profile's).
    streams : the streams that must keep arriving while commanding (names of
        :data:`STREAMS`).
    min_rates_hz : the slowest rate [Hz, sample time] each stream may arrive at (the
        precheck's minimum); a stream not named is lost after ``link_timeout_s``.
    """

    def __init__(self, limits: ProcedureLimits, *, depth_excursion_m: float | None = None,
                 streams: tuple[str, ...] = tuple(STREAMS),
                 min_rates_hz: Mapping[str, float] | None = None) -> None:
        self.limits = limits
        self.depth_excursion_m = (limits.max_depth_excursion_m if depth_excursion_m is None
                                  else depth_excursion_m)
        self.commanding = False
        self.depth_ref_m = math.nan
        self.what = "the hold's start depth"
        self._streams = streams
        self._t_stream = dict.fromkeys(streams, math.nan)
        rates = min_rates_hz or {}
        self._stream_timeout_s = {
            name: max(limits.link_timeout_s, STREAM_MISSED_PERIODS / rates[name])
            if rates.get(name, 0) > 0 else limits.link_timeout_s for name in streams}
        self._t_commanding = math.nan
        self._t_sample = math.nan

    def start(self, t_s: float, depth_ref_m: float, what: str) -> None:
        """Commanding starts (or moves to a new set-point) at ``t_s``: depth is held
        around ``depth_ref_m`` [m], called ``what`` in messages."""
        if not self.commanding:
            self._t_commanding = t_s
        self.commanding = True
        self.depth_ref_m, self.what = depth_ref_m, what

    def sample(self, s: Sample) -> Stop | None:
        """Check one sample; a :class:`Stop` when it breaks a rule."""
        self._t_sample = s.t_s if math.isnan(self._t_sample) else max(self._t_sample, s.t_s)
        for name in self._streams:
            if isinstance(s, STREAMS[name]):
                self._t_stream[name] = s.t_s
        if isinstance(s, Health):
            if not s.connected:
                return Stop(f"link lost: {s.detail or 'vehicle gone'}", Cause.LINK)
            if not s.armed and self.commanding:
                return Stop("the vehicle disarmed while trimd commanded it", Cause.VEHICLE)
        if not self.commanding:
            return None
        if isinstance(s, PilotInput):
            return Stop(f"the pilot took over ({s.source}): trimd released control", Cause.PILOT)
        if isinstance(s, Depth) and abs(s.depth_m - self.depth_ref_m) > self.depth_excursion_m:
            return Stop(f"depth excursion: {s.depth_m - self.depth_ref_m:+.2f} m from "
                        f"{self.what} (limit ±{self.depth_excursion_m:g} m)", Cause.ENVELOPE)
        if isinstance(s, Attitude):
            limit = self.limits.max_tilt_deg + ENVELOPE_MARGIN_DEG
            roll, pitch = math.degrees(s.phi), math.degrees(s.theta)
            if max(abs(roll), abs(pitch)) > limit:
                return Stop(f"attitude out of envelope: roll {roll:.1f}°, pitch {pitch:.1f}° "
                            f"(limit {limit:.0f}°)", Cause.ENVELOPE)
        return None

    def time(self, t_s: float) -> Stop | None:
        """Check the silence of the link, and of each stream, at ``t_s`` (a sample's time
        or a Tick's)."""
        timeout = self.limits.link_timeout_s
        silent = t_s - self._t_sample
        if silent > timeout:
            return Stop(f"link lost: no telemetry for {silent:.1f} s", Cause.LINK)
        if not self.commanding:
            return None
        for name, last in self._t_stream.items():
            quiet = t_s - (last if last >= self._t_commanding else self._t_commanding)
            if quiet > self._stream_timeout_s[name]:
                return Stop(f"link lost: no {name} for {quiet:.1f} s while commanding",
                            Cause.LINK)
        return None
