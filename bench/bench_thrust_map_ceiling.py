"""What a calibration of the thrust map could at best give (issue 24, docs/method.md §7):
the same trim with the profile alone and with parts of the simulated vehicle's true
thrust map handed to trimd (what trimd's own calibration gives:
:mod:`bench.bench_calibration`).

Per seed and case (:data:`bench.bench_sim_coverage.CASES`, ``truth=perturbed``: thrust
curves 5 % off, ESC bands up to 4 µs off with outputs hunting at their edge), each trim
the seed's own dive (:func:`bench.bench_calibration.judged_trim`), judged by the TRUE q:

- ``profile``: the profile alone;
- ``gains known``, ``bands known``, ``map known``: trimd estimates with the true curves'
  gains, the true ESC bands, or both (:func:`trimd.drivers.sim.truth.true_thrusters`),
  its ± still the profile's prior;
- ``map exact``: both, and a calibration posterior of σ → 0 (what a perfect calibration
  would give: the stop rule collects on, since the thrust map no longer dominates the ±).

Printed per case and trim: the RMS error of W − B [N] and of each net moment
[mm-equivalent], the share of 95 % intervals covering the truth and the mean 1σ, beside
issue 24's targets (:data:`bench.bench_calibration.TARGETS`). ``TRIMD_CEILING_SEEDS``
(default 30), ``TRIMD_CEILING_OPTIONS``, ``TRIMD_CEILING_CASES``,
``TRIMD_COVERAGE_PROCESSES`` as in :mod:`bench.bench_calibration`. One seed takes ≈ 25 s
(Heavy) and ≈ 30 s (Sabertooth) of one core: five trims.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from bench.bench_calibration import EXACT_STD, OPTIONS, TARGETS, judged_trim
from bench.bench_sim_coverage import (
    CASES,
    NAMES,
    Run,
    coverage,
    picked,
    rms_errors,
    run_seeds,
    seeding,
)
from bench.size import size, sized_profile
from trimd.core.calibration import posterior
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.truth import true_thrusters
from trimd.drivers.sim.vehicle import SimVehicle

#: The trims with the true thrust map in part: label → (gains, bands, exact).
KNOWN = {"gains known": (True, False, False), "bands known": (False, True, False),
         "map known": (True, True, False), "map exact": (True, True, True)}


def known_map(profile: Profile, *, gains: bool, bands: bool, exact: bool = False
              ) -> Callable[[SimVehicle], Profile]:
    """``profile`` with the simulated vehicle's true thrust curves in part (gains, bands)
    and, ``exact``, a calibration posterior of σ :data:`EXACT_STD`, as trimd is to estimate
    with it (:func:`tests.helpers.sim_trim`'s ``estimate_with``)."""
    def known(vehicle: SimVehicle) -> Profile:
        known = dataclasses.replace(profile, thrusters=true_thrusters(
            profile, vehicle.offset, gains=gains, bands=bands))
        if not exact:
            return known
        k = 4 * len(profile.thrusters)
        return dataclasses.replace(known, thrust_map=posterior(
            np.zeros(k), EXACT_STD**2 * np.eye(k), 1))
    return known


def run(name: str, payload: str, seed: int, options: str) -> tuple[tuple[str, Run], ...]:
    """The trims of ``seed`` (module docstring), each with its label; at the tiny size the
    profile's and the exact map's only, each hold collecting for less
    (:func:`bench.size.sized_profile`)."""
    profile = sized_profile(load_profile(name))
    runs = [("profile", judged_trim(profile, payload, seed, options)[0])]
    for label, (gains, bands, exact) in KNOWN.items():
        if label in size(KNOWN, ("map exact",)):
            runs.append((label, judged_trim(profile, payload, seed, options, known_map(
                profile, gains=gains, bands=bands, exact=exact))[0]))
    return tuple(runs)


def report(seeds: list[tuple[tuple[str, Run], ...]], profile: Profile) -> list[str]:
    """The figures of ``seeds`` for people (module docstring), one string per line."""
    target_wb, target_m = TARGETS[profile.name]
    lines = [f"  {'':12s} {'':22s}" + " ".join(f"{n:>8s}" for n in NAMES[:4])]
    for k, (label, _) in enumerate(seeds[0]):
        runs = [s[k][1] for s in seeds]
        done = [r for r in runs if r.sigma is not None]
        sigma = np.mean([r.sigma[:4] for r in done], axis=0) if done else np.full(4, np.nan)
        sigma[1:] *= 1e3 / profile.weight_N
        for what, values, form in (("rms error (N, mm-eq)", rms_errors(runs, profile.weight_N),
                                    "8.3f"),
                                   ("95 % interval covers", coverage(runs)[0][:4], "8.0%"),
                                   ("mean ± 1σ (N, mm-eq)", sigma, "8.3f")):
            lines.append(f"  {label:12s} {what:22s} " + " ".join(f"{v:{form}}" for v in values))
        lines.append(f"  {label:12s} {'trims done':22s} {len(done)}/{len(runs)}")
    wb = "—" if target_wb is None else f"{target_wb:.3g} N"
    lines.append(f"  issue 24's targets (rms, calibrated): W − B {wb}, each net moment "
                 f"{target_m:.3g} mm-equivalent")
    return lines


def main() -> None:
    cfg = seeding("CEILING", size(30, 1), OPTIONS)
    for name, payload in picked(size(CASES, CASES[:1]), cfg.wanted):
        runs, wall = run_seeds(run, name, payload, cfg.seeds, cfg.options, cfg.processes)
        print(f"{name}, {payload}, sim:{cfg.options}: {cfg.seeds} seeds, {wall:.1f} s wall "
              "per seed")
        for line in report(runs, load_profile(name)):
            print(f"  {line}")
