"""Holds under slow attitude wander driven by disturbance torques the thrusters fight
(issue 22): full trims of the simulated vehicles with ``disturb=real,truth=perturbed`` plus
roll and pitch torques sized for ``torque_wander_deg`` RMS of attitude wander at
``torque_wander_tau_s`` correlation (:mod:`trimd.drivers.sim.wander`). Per setting: how
many trims end DONE (every hold settled within ``settle_timeout_s``), the coverage of the
95 % intervals of W − B and the three net moments, and the simulated time a trim took.

``TRIMD_WANDER_SEEDS`` (default 40) seeds per setting; ``TRIMD_COVERAGE_PROCESSES``
(default 1) worker processes.
"""

from __future__ import annotations

import itertools
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from bench.bench_sim_coverage import CASES, NAMES, coverage, run
from bench.size import size

#: (RMS attitude wander [deg], correlation time [s]) of the disturbance torques
SETTINGS = tuple(itertools.product((0.1, 0.2), (2.0, 20.0)))


def main() -> None:
    seeds = int(os.environ.get("TRIMD_WANDER_SEEDS", size(40, 1)))
    processes = int(os.environ.get("TRIMD_COVERAGE_PROCESSES", "1"))
    cases = size([CASES[0], CASES[-1]], [CASES[0]])   # the Heavy at a slot, the Sabertooth
    print(f"{seeds} seeds per setting; columns: {', '.join(NAMES[:4])}")
    for (name, payload), (deg, tau_s) in itertools.product(cases, size(SETTINGS, SETTINGS[:1])):
        options = (f"disturb=real,truth=perturbed,torque_wander_deg={deg},"
                   f"torque_wander_tau_s={tau_s}")
        with ProcessPoolExecutor(processes) as pool:
            runs = list(pool.map(run, [name] * seeds, [payload] * seeds, range(seeds),
                                 [options] * seeds))
        covered, rms, done = coverage(runs)
        print(f"{name} {payload}, wander {deg}° at {tau_s:g} s: {done}/{seeds} settled and "
              f"done, {np.mean([r.sim_s for r in runs]):.0f} s simulated per trim; cover "
              + " ".join(f"{c:.0%}" for c in covered[:4])
              + "; rms z " + " ".join(f"{v:.2f}" for v in rms[:4]))
        for r in [r for r in runs if r.error is None][:2]:
            print(f"  seed {r.seed}: {r.outcome[:100]}")
