"""Holds under slow attitude wander driven by disturbance torques the thrusters fight
(issue 22): full trims of the simulated vehicles with ``disturb=real,truth=perturbed`` plus
roll and pitch torques sized for ``torque_wander_deg`` RMS of attitude wander at
``torque_wander_tau_s`` correlation (:mod:`trimd.drivers.sim.wander`). Per setting: how
many trims end DONE (every hold settled within ``settle_timeout_s``), the coverage of the
95 % intervals of W − B and the three net moments, the simulated time a trim took, and
the attitude wander the setting actually leaves on that vehicle holding level.

``TRIMD_WANDER_SEEDS`` (default 40) seeds per setting; ``TRIMD_COVERAGE_PROCESSES``
(default 1) worker processes.
"""

from __future__ import annotations

import itertools
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from numpy.typing import NDArray

from bench.bench_sim_coverage import CASES, NAMES, coverage, run
from bench.size import size
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.config import parse_sim_options
from trimd.drivers.sim.vehicle import SimVehicle

FloatArray = NDArray[np.float64]
#: (RMS attitude wander [deg], correlation time [s]) of the disturbance torques
SETTINGS = tuple(itertools.product((0.1, 0.2), (2.0, 20.0)))


def actual_wander_deg(name: str, payload: str, options: str, seconds: float) -> FloatArray:
    """RMS [deg] of the true roll and pitch about their mean while the simulated vehicle of
    ``options`` holds level for ``seconds`` (after 30 s to settle), seed 0: what the
    torques' setting leaves on that vehicle (the linear sizing leaves out the dead band,
    where the Heavy's loop is weak)."""
    v = SimVehicle(load_profile(name), parse_sim_options(f"payload={payload},{options}"))
    v.run_for(30.0)
    angles = []
    for _ in range(int(seconds * 10)):
        v.run_for(0.1)
        angles.append(v.truth.eta[3:5])
    std: FloatArray = np.degrees(np.std(angles, axis=0))
    return std


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
        roll, pitch = actual_wander_deg(name, payload, options, size(300.0, 10.0))
        print(f"{name} {payload}, wander {deg}° at {tau_s:g} s (actual roll {roll:.2f}°, "
              f"pitch {pitch:.2f}°): {done}/{seeds} settled and "
              f"done, {np.mean([r.sim_s for r in runs]):.0f} s simulated per trim; cover "
              + " ".join(f"{c:.0%}" for c in covered[:4])
              + "; rms z " + " ".join(f"{v:.2f}" for v in rms[:4]))
        for r in [r for r in runs if r.error is None][:2]:
            print(f"  seed {r.seed}: {r.outcome[:100]}")
