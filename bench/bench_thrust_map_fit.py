"""The thrust map fitted to many level calibration experiments (issue 24, docs/method.md
§7): the trim after a calibration of a weight and a float at each corner.

trimd's calibration (:func:`trimd.core.calibration.calibrate`) fits each thruster's curve
scaled by its gains and its ESC band shifted by its offsets to the experiments' holds'
thruster outputs (:mod:`trimd.core.thrust_fit`). Per seed and case (``truth=perturbed``,
realistic disturbances): the trim with the profile alone, then with the calibration of
the first half and of all of :data:`PLAN`'s experiments (a weight and a float of the same
size at each corner: ``trimd calibrate``'s series,
:func:`trimd.app.calibrate.calibrate_with_weights`, nine level holds of ``collect_max_s``
sharing eight experiments), judged by the TRUE q, and
the share of 95 % intervals covering it.

``TRIMD_FIT_SEEDS`` (default 16), ``TRIMD_FIT_CASES``, ``TRIMD_COVERAGE_PROCESSES`` as in
:mod:`bench.bench_calibration`. One seed takes ≈ 40 s of one core (the Heavy): three trims
and nine level holds.
"""

from __future__ import annotations

import asyncio
import dataclasses
from collections.abc import Awaitable

from bench.bench_calibration import NOISE, OPTIONS, TARGETS, judged_trim, known_weight
from bench.bench_sim_coverage import CASES, Run, coverage, picked, rms_errors, run_seeds, seeding
from bench.bench_thrust_map_ceiling import FLOAT_PCT
from bench.size import size, sized_profile
from trimd.app.calibrate import CalibrationRun, KnownWeight, calibrate_with_weights
from trimd.app.connect import open_link
from trimd.core.calibration import calibrate
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile

#: profile → the experiments: (slot, +1 the known weight of
#: :data:`bench.bench_calibration.WEIGHTS`, −1 a float of the same size).
PLAN = {"bluerov2-heavy": (("W-front-stbd", 1), ("W-aft-port", -1), ("W-front-port", 1),
                           ("W-aft-stbd", -1), ("W-front-stbd", -1), ("W-aft-port", 1),
                           ("W-front-port", -1), ("W-aft-stbd", 1)),
        "sabertooth-dh2": (("FrontSB", 1), ("AftP", -1), ("FrontP", 1), ("AftSB", -1),
                           ("FrontSB", -1), ("AftP", 1), ("FrontP", -1), ("AftSB", 1))}


def series(profile: Profile, payload: str, seed: int, options: str,
           weights: list[KnownWeight]) -> CalibrationRun:
    """trimd's calibration with the series ``weights`` of the vehicle of ``seed``, each
    level hold another dive's noise and disturbances (``seed`` + k·NOISE), stored
    nowhere."""
    opened: list[str] = []

    def opener() -> Awaitable[Link]:
        extra = ""
        if opened:
            w = weights[len(opened) - 1]
            x, y, z = profile.slot(w.slot).position_m
            extra = f"+{w.kg:.6f}@{x},{y},{z}"
        opened.append(extra)
        return open_link(f"sim:payload={payload}{extra},seed={seed + len(opened) * NOISE},"
                         f"truth_seed={seed},{options}", profile)

    return asyncio.run(calibrate_with_weights(opener, profile, weights, lambda _text: True,
                                              db=None, vehicle="bench", wall_clock=False))


def run(name: str, payload: str, seed: int, options: str) -> tuple[tuple[str, Run], ...]:
    """The trims of ``seed``, each with its label (module docstring); at the tiny size one
    experiment."""
    profile = sized_profile(load_profile(name))
    weight = known_weight(profile)
    runs = [("profile alone", judged_trim(profile, payload, seed, options)[0])]
    plan = PLAN[name][:size(len(PLAN[name]), 1)]
    done = series(profile, payload, seed, options, [
        KnownWeight(sign * weight.kg, slot, weight.uncertainty_pct if sign > 0 else FLOAT_PCT)
        for slot, sign in plan])
    for k in sorted({max(1, len(plan) // 2), len(plan)}):
        cal = calibrate(done.experiments[:k], profile)
        calibrated = dataclasses.replace(profile, thrust_map=cal.posterior)
        label = f"{cal.posterior.experiments} of {k} experiments learnt"
        runs.append((label, judged_trim(profile, payload, seed, options,
                                        lambda _v, p=calibrated: p)[0]))
    return tuple(runs)


def main() -> None:
    cfg = seeding("FIT", size(16, 1), OPTIONS)
    for name, payload in picked(size(CASES, CASES[:1]), cfg.wanted):
        runs, wall = run_seeds(run, name, payload, cfg.seeds, cfg.options, cfg.processes)
        profile = load_profile(name)
        print(f"{name}, {payload}, sim:{cfg.options}: {cfg.seeds} seeds, {wall:.1f} s wall "
              "per seed; RMS error of W − B [N], x, y, z net [mm-equivalent]")
        for k, (label, _) in enumerate(runs[0]):
            judged = [r[k][1] for r in runs]
            rms = rms_errors(judged, profile.weight_N)
            covers = coverage(judged)[0][:4]
            print(f"    {label:28s}" + " ".join(f"{v:8.3f}" for v in rms)
                  + "   95 % covers " + " ".join(f"{100 * c:3.0f}%" for c in covers))
        target_wb, target_m = TARGETS[profile.name]
        wb = "—" if target_wb is None else f"{target_wb:.3g} N"
        print(f"    issue 24's targets: W − B {wb}, each net moment {target_m:.3g} mm-equivalent")
