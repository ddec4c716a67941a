"""Before trimd commands a vehicle: the one precheck every commanding machine uses (the trim
:class:`~trimd.core.procedure.Procedure` and the excitation
:class:`~trimd.identify.experiment.Excite`).

trimd takes control only of a vehicle that is armed, in a mode the pilot flies (not one
in which it follows its own plan or failsafe: :data:`BUSY_CLASSES`, the mode's
:class:`~trimd.core.samples.ModeClass` as the driver decided it), with every stream it
steers by arriving at its minimum rate, and holding depth. Rates and depth are judged
over the trailing :data:`PRECHECK_WINDOW_S` of the samples' own time [s].
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping

from trimd.core.samples import Attitude, Depth, Health, ModeClass, Sample, Thrusters

__all__ = ["BUSY_CLASSES", "DEPTH_STABLE_SHARE", "PRECHECK_WINDOW_S", "Precheck"]

#: Mode classes in which the vehicle follows its own plan, failsafe or routine: trimd
#: does not take over. (An UNKNOWN mode is not refused: the pilot may fly a vehicle whose
#: modes its driver does not know.)
BUSY_CLASSES = frozenset({ModeClass.AUTONOMOUS, ModeClass.FAILSAFE, ModeClass.SERVICE})
#: The window [s] over which rates and depth are judged.
PRECHECK_WINDOW_S = 5.0
#: Depth may wander by this share of max_depth_excursion_m over the window.
DEPTH_STABLE_SHARE = 0.5
_KINDS: dict[type[Sample], str] = {Attitude: "attitude", Thrusters: "thrusters",
                                   Depth: "depth"}


class Precheck:
    """What keeps trimd from commanding now, from the samples seen so far.

    Parameters
    ----------
    min_rates_hz : the streams that must arrive ("attitude", "thrusters", "depth") and
        their minimum rates [Hz of sample time].
    max_depth_excursion_m : the profile's depth envelope [m]; depth may wander by
        :data:`DEPTH_STABLE_SHARE` of it over the window.
    """

    def __init__(self, min_rates_hz: Mapping[str, float], max_depth_excursion_m: float
                 ) -> None:
        self.min_rates_hz = dict(min_rates_hz)
        self.depth_limit_m = DEPTH_STABLE_SHARE * max_depth_excursion_m
        self._arrivals: dict[str, deque[float]] = {k: deque() for k in self.min_rates_hz}
        self._depths: deque[tuple[float, float]] = deque()
        self.health: Health | None = None

    def sample(self, s: Sample) -> None:
        """Record one sample (its arrival, a depth, the latest health)."""
        if isinstance(s, Health):
            self.health = s
            return
        kind = _KINDS.get(type(s))
        if kind in self._arrivals:
            times = self._arrivals[kind]
            times.append(s.t_s)
            while times[0] < s.t_s - PRECHECK_WINDOW_S:
                times.popleft()
        if isinstance(s, Depth):
            self._depths.append((s.t_s, s.depth_m))
            while self._depths[0][0] < s.t_s - PRECHECK_WINDOW_S:
                self._depths.popleft()

    def problems(self, t_s: float) -> list[str]:
        """What keeps trimd from commanding at ``t_s`` [s], for people (empty: nothing):
        telemetry rates, arming, mode, depth."""
        out = []
        for stream, need in self.min_rates_hz.items():
            recent = [t for t in self._arrivals[stream] if t > t_s - PRECHECK_WINDOW_S]
            rate = len(recent) / PRECHECK_WINDOW_S
            if rate < need:
                out.append(f"{stream} at {rate:.1f} Hz (need ≥ {need:g} Hz)")
        h = self.health
        if h is not None and h.armed is None:
            out.append("the vehicle does not say whether it is armed")
        elif h is not None and not h.armed:
            out.append("vehicle disarmed: arm it")
        if h is not None and h.mode_class in BUSY_CLASSES:
            out.append(f"vehicle in {h.mode} ({h.mode_class.value}): switch it to a mode "
                       "the pilot flies (manual, stabilised or depth-holding: e.g. MANUAL, "
                       "STABILIZE or ALT_HOLD)")
        depths = [d for _, d in self._depths]
        if depths and max(depths) - min(depths) > self.depth_limit_m:
            out.append(f"depth not steady: {max(depths) - min(depths):.2f} m of change in "
                       f"{PRECHECK_WINDOW_S:g} s (limit {self.depth_limit_m:g} m): hold depth "
                       "first, e.g. in ALT_HOLD")
        return out
