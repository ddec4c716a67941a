"""The trim watch's change test on a simulated vehicle during scripted dives (the BlueROV2
Heavy, or ``TRIMD_WATCH_PROFILE``).

False alarms: ``TRIMD_WATCH_SEEDS`` (default 3) dives of ``TRIMD_WATCH_HOURS`` (default 2)
simulated hours each, with the sim options ``TRIMD_WATCH_OPTIONS`` (default
``pilot=dive,disturb=real,truth=perturbed``: the scripted pilot, realistic disturbances,
a vehicle that differs from its profile) and no change: the alerts per hour, the
crossings of the CUSUM threshold per hour (alerts plus those too small to matter), the
segments per hour, and the RMS of the standardised innovation of each tested quantity
against the baseline (1 when the segments' ± is right; the threshold assumes it).

Detection: ``TRIMD_WATCH_LEAK_SEEDS`` (default 2) dives with a leak of 0.5 N/min from
300 s: how long after its start the first alert came, and its change against the water
then in, in units of its σ. One simulated hour takes ≈ 2–3 min of one core.
"""

from __future__ import annotations

import asyncio
import os
import time
from collections.abc import Callable

import numpy as np

from bench.size import size
from trimd.app.watch import watch_link
from trimd.core.change import COMPONENTS
from trimd.core.profile_yaml import load_profile
from trimd.core.watch import TrimWatch
from trimd.drivers.sim.config import parse_sim_options
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle

#: the vehicle watched (``TRIMD_WATCH_PROFILE``, a profile name or path)
PROFILE = os.environ.get("TRIMD_WATCH_PROFILE", "bluerov2-heavy")
LEAK_N_MIN, LEAK_START_S = 0.5, 300.0


def dive(options: str, seconds: float) -> tuple[TrimWatch, SimVehicle]:
    """Watch one simulated dive of ``seconds`` with ``options``; the watch and the
    vehicle at the end (its truth)."""
    profile = load_profile(PROFILE)
    watch = TrimWatch(profile)
    vehicle = SimVehicle(profile, parse_sim_options(options))
    asyncio.run(watch_link(SimLink(vehicle), watch, lambda r: None, until_s=seconds))
    return watch, vehicle


def innovations(watch: TrimWatch) -> np.ndarray:
    """Standardised innovations (segments × tested quantities) of the segments after the
    baseline, against it, as the test computes them (NaN where not observed)."""
    det = watch.detector
    if det is None:
        return np.zeros((0, len(COMPONENTS)))
    b = det.baseline
    rows = []
    for s in watch.segments:
        if s.baseline:
            continue
        e = s.estimate
        row = []
        for i in COMPONENTS:
            g = e.gain_sensitivity[i] - (b.gain_sensitivity[i] if b.gain_sensitivity is not None
                                         else 0.0)
            var = e.q_cov_noise[i, i] + watch.floor_var[i] + g @ g + b.var[i]
            row.append((e.q[i] - b.q[i]) / np.sqrt(var) if e.observable[i] else np.nan)
        rows.append(row)
    return np.array(rows)


def no_change(options: str, seeds: int, hours: float,
              seen: Callable[[int, TrimWatch, SimVehicle], None] = lambda *_: None) -> None:
    """Print the false alarms, threshold crossings and innovations of ``seeds`` dives of
    ``hours`` each with ``options``; ``seen`` is shown each dive as well."""
    print(f"no change: {seeds} dive(s) of {hours:g} h, sim:{options}")
    total_h, alarms, crossings, segments, z = 0.0, 0, 0, 0, []
    for seed in range(seeds):
        t0 = time.perf_counter()
        w, vehicle = dive(f"{options},seed={seed}", hours * 3600)
        seen(seed, w, vehicle)
        total_h += hours
        alarms += len(w.alerts)
        suppressed = w.detector.suppressed if w.detector is not None else 0
        crossings += len(w.alerts) + suppressed
        segments += len(w.segments)
        z.append(innovations(w))
        print(f"  seed {seed}: {len(w.segments)} segments, {len(w.alerts)} alert(s) "
              f"({suppressed} crossing(s) too small to matter) "
              f"{[a.text for a in w.alerts]}, not counted {w.rejected}, breaks {w.breaks}, "
              f"h = {w.h:.2f} σ, {time.perf_counter() - t0:.0f} s wall")
    zz = np.concatenate(z) if z else np.zeros((0, 3))
    rms = np.sqrt(np.nanmean(zz**2, axis=0)) if len(zz) else np.full(3, np.nan)
    print(f"threshold crossings: {crossings} in {total_h:g} h = {crossings / total_h:.2f} per "
          "hour (the nominal rate assumes independent segments)")
    print(f"false alarms: {alarms} in {total_h:g} h = {alarms / total_h:.3f} per hour "
          f"({segments / total_h:.1f} segments per hour); RMS standardised innovation "
          f"W − B {rms[0]:.2f}, x net {rms[1]:.2f}, y net {rms[2]:.2f}")


def leak(options: str, seeds: int, seconds: float = 1200.0) -> list[float]:
    """Print when a leak of :data:`LEAK_N_MIN` from :data:`LEAK_START_S` was alerted in
    ``seeds`` dives of ``seconds`` with ``options``; the delays [s] (inf: no alert)."""
    print(f"leak {LEAK_N_MIN} N/min from {LEAK_START_S:g} s: {seeds} dive(s) of "
          f"{seconds / 60:g} min")
    delays = []
    for seed in range(seeds):
        w, _ = dive(f"{options},seed={100 + seed},leak_N_min={LEAK_N_MIN},"
                    f"leak_start_s={LEAK_START_S}", seconds)
        first = next((a.alert for a in w.alerts if a.alert.component == 0), None)
        if first is None:
            print(f"  seed {100 + seed}: no alert")
            delays.append(float("inf"))
            continue
        seg = next(s.estimate for s in w.segments if s.estimate.t_end_s == first.at_s)
        leaked = LEAK_N_MIN / 60 * ((seg.t_start_s + seg.t_end_s) / 2 - LEAK_START_S)
        delays.append(first.at_s - LEAK_START_S)
        print(f"  seed {100 + seed}: alert {first.at_s - LEAK_START_S:.0f} s after the "
              f"start: {first.total:+.2f} ± {first.total_std:.2f} N against {leaked:.2f} N "
              f"in ({(first.total - leaked) / first.total_std:+.1f} σ); "
              f"{[a.text for a in w.alerts[:1]]}")
    return delays


def main() -> None:
    seeds = int(os.environ.get("TRIMD_WATCH_SEEDS", size(3, 1)))
    hours = float(os.environ.get("TRIMD_WATCH_HOURS", size(2.0, 0.05)))
    options = os.environ.get("TRIMD_WATCH_OPTIONS", "pilot=dive,disturb=real,truth=perturbed")
    no_change(options, seeds, hours)
    leak(options, int(os.environ.get("TRIMD_WATCH_LEAK_SEEDS", size(2, 1))),
         size(1200.0, 320.0))
