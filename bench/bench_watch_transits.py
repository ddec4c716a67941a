"""The trim watch on dives of level transits and stops, with no stick telemetry.

The simulated BlueROV2 Heavy flies the ``transits`` pilot (every minute a 20 s transit at
35 % forward stick ending in a turn, then 40 s stopped, the last 36 s with the sticks at
neutral; ALT_HOLD, level within ≈ 2°) with
the sim options ``TRIMD_WATCH_TRANSIT_OPTIONS`` (default :data:`OPTIONS`: realistic
disturbances, a vehicle that differs from its profile, and ArduSub's stiffer attitude
loop, 6 rad/s, so that the vehicle stays level when a transit starts and stops).

No change: ``TRIMD_WATCH_TRANSIT_SEEDS`` (default 40) dives of
``TRIMD_WATCH_TRANSIT_HOURS`` (default 0.1) simulated hours each, one vehicle per seed (a
segment's error is mostly its vehicle's thrust map, so the coverage needs many vehicles,
not long dives): the share of the stops of at least :data:`MIN_STOP_S` that gave a segment
(target ≥ 80 %), segments that overlap a transit (target none), the share of segments whose
W − B is within its 95 % interval of the truth (target 90–99 %), and the false alarms
(target none in ≥ 2 h). Leak: ``TRIMD_WATCH_TRANSIT_LEAK_SEEDS`` (default 2) dives with 0.5
N/min from 300 s: the first alert within :data:`LEAK_WITHIN_S` of its start. One simulated
hour takes ≈ 2 min of one core.
"""

from __future__ import annotations

import os

import numpy as np

from bench.bench_watch import leak, no_change
from bench.size import size
from trimd.core.watch import TrimWatch
from trimd.drivers.sim.scenario import TRANSITS, TRANSITS_RAMP_S
from trimd.drivers.sim.vehicle import SimVehicle

OPTIONS = "pilot=transits,attitude_bandwidth_rad_s=6,disturb=real,truth=perturbed"
#: Stops at least this long [s] should give a segment.
MIN_STOP_S = 30.0
#: The leak's first alert within this long of its start [s].
LEAK_WITHIN_S = 180.0


def stops(until_s: float) -> list[tuple[float, float]]:
    """(start, end) [s] of the script's stops, from the sticks' return to neutral, of at
    least :data:`MIN_STOP_S` that end by ``until_s``."""
    out, t = [], 0.0
    while t < until_s:
        for duration, sticks in TRANSITS:
            start, end = t + TRANSITS_RAMP_S, t + duration
            if not any(sticks) and end - start >= MIN_STOP_S and end <= until_s:
                out.append((start, end))
            t += duration
    return out


class Tally:
    """Stops with a segment, segments in a transit, segments covering the truth."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.stops = self.found = self.in_transit = self.segments = self.covered = 0
        self.z: list[float] = []

    def __call__(self, seed: int, watch: TrimWatch, vehicle: SimVehicle) -> None:
        spans = [(s.estimate.t_start_s, s.estimate.t_end_s) for s in watch.segments]
        windows = stops(self.seconds)
        inside = [any(a <= t0 and t1 <= b for a, b in windows) for t0, t1 in spans]
        found = sum(any(a <= t0 and t1 <= b for t0, t1 in spans) for a, b in windows)
        truth = float(vehicle.truth.mass.net[0])
        z = [(s.estimate.q[0] - truth) / s.estimate.q_std[0] for s in watch.segments]
        covered = sum(abs(x) <= 1.96 for x in z)
        self.z += z
        self.stops += len(windows)
        self.found += found
        self.in_transit += inside.count(False)
        self.segments += len(spans)
        self.covered += covered
        print(f"  seed {seed}: {found} of {len(windows)} stops gave a segment, "
              f"{inside.count(False)} segment(s) outside the stops, W − B within its 95 % "
              f"interval in {covered} of {len(spans)} (truth {truth:+.3f} N)")

    def summary(self) -> str:
        return (f"stops of ≥ {MIN_STOP_S:g} s with a segment: {self.found} of {self.stops} "
                f"({100 * self.found / max(self.stops, 1):.0f} %, target ≥ 80 %); segments "
                f"outside the stops: {self.in_transit} (target 0); W − B within its 95 % "
                f"interval of the truth: {self.covered} of {self.segments} "
                f"({100 * self.covered / max(self.segments, 1):.0f} %, target 90–99 %; "
                f"|error|/σ median {np.median(np.abs(self.z)):.2f}, 95th percentile "
                f"{np.percentile(np.abs(self.z), 95):.2f})")


def main() -> None:
    seeds = int(os.environ.get("TRIMD_WATCH_TRANSIT_SEEDS", size(40, 1)))
    hours = float(os.environ.get("TRIMD_WATCH_TRANSIT_HOURS", size(0.1, 0.05)))
    options = os.environ.get("TRIMD_WATCH_TRANSIT_OPTIONS", OPTIONS)
    tally = Tally(hours * 3600)
    no_change(options, seeds, hours, tally)
    print(tally.summary())
    delays = leak(options, int(os.environ.get("TRIMD_WATCH_TRANSIT_LEAK_SEEDS", size(2, 1))),
                  size(1200.0, 320.0))
    within = sum(d <= LEAK_WITHIN_S for d in delays)
    print(f"leak alerted within {LEAK_WITHIN_S:g} s of its start: {within} of {len(delays)}")
