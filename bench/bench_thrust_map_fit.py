"""The thrust map fitted to many level calibration experiments (issue 24, docs/method.md
§7): the trim after a calibration of a weight and a float at each corner.

trimd's calibration (:func:`trimd.core.calibration.calibrate`) fits each thruster's curve
scaled by its gains and its ESC band shifted by its offsets to the experiments' holds'
thruster outputs (:mod:`trimd.core.thrust_fit`). Per seed and case (``truth=perturbed``,
realistic disturbances): the trim with the profile alone, then with the calibration of
the first half and of all of :data:`PLAN`'s experiments (a weight and a float of the same
size at each corner, each between two level holds of ``collect_max_s``, as
:func:`trimd.app.calibrate.calibration_experiment` makes them), judged by the TRUE q, and
the share of 95 % intervals covering it.

``TRIMD_FIT_SEEDS`` (default 16), ``TRIMD_FIT_CASES``, ``TRIMD_COVERAGE_PROCESSES`` as in
:mod:`bench.bench_calibration`. One seed takes ≈ 40 s of one core (the Heavy): three trims
and sixteen level holds.
"""

from __future__ import annotations

import asyncio
import dataclasses

from bench.bench_calibration import NOISE, OPTIONS, TARGETS, judged_trim, known_weight
from bench.bench_sim_coverage import CASES, Run, coverage, picked, rms_errors, run_seeds, seeding
from bench.bench_thrust_map_ceiling import FLOAT_PCT
from bench.size import size, sized_profile
from trimd.app.calibrate import KnownWeight, calibration_experiment, level_hold_procedure
from trimd.app.connect import open_link
from trimd.app.session import Session
from trimd.core.calibration import calibrate
from trimd.core.estimate import HoldSamples
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile

#: profile → the experiments: (slot, +1 the known weight of
#: :data:`bench.bench_calibration.WEIGHTS`, −1 a float of the same size).
PLAN = {"bluerov2-heavy": (("W-front-stbd", 1), ("W-aft-port", -1), ("W-front-port", 1),
                           ("W-aft-stbd", -1), ("W-front-stbd", -1), ("W-aft-port", 1),
                           ("W-front-port", -1), ("W-aft-stbd", 1)),
        "sabertooth-dh2": (("FrontSB", 1), ("AftP", -1), ("FrontP", 1), ("AftSB", -1),
                           ("FrontSB", -1), ("AftP", 1), ("FrontP", -1), ("AftSB", 1))}


def level_hold(profile: Profile, url: str) -> HoldSamples:
    """One level hold on ``url``: its samples (with the thruster outputs behind them)."""
    async def go() -> HoldSamples:
        link = await open_link(url, profile)
        try:
            result = await Session(link, profile, recorder=None, presenters=[],
                                   procedure=level_hold_procedure(profile, confirmed=True),
                                   wall_clock=False).run()
        finally:
            await link.close()
        assert result.verification is not None, result.reason
        return result.verification
    return asyncio.run(go())


def run(name: str, payload: str, seed: int, options: str) -> tuple[tuple[str, Run], ...]:
    """The trims of ``seed``, each with its label (module docstring); at the tiny size one
    experiment."""
    profile = sized_profile(load_profile(name))
    weight = known_weight(profile)
    runs = [("profile alone", judged_trim(profile, payload, seed, options)[0])]
    plan = PLAN[name][:size(len(PLAN[name]), 1)]
    experiments = []
    for k, (slot, sign) in enumerate(plan):
        x, y, z = profile.slot(slot).position_m
        kg = sign * weight.kg

        def url(extra: str, dive: int) -> str:
            return (f"sim:payload={payload}{extra},seed={seed + dive * NOISE},"
                    f"truth_seed={seed},{options}")
        before = level_hold(profile, url("", 2 * k + 1))
        after = level_hold(profile, url(f"+{kg:.6f}@{x},{y},{z}", 2 * k + 2))
        experiments.append(calibration_experiment(before, after, profile, KnownWeight(
            kg, slot, weight.uncertainty_pct if sign > 0 else FLOAT_PCT)))
        if k + 1 in (len(plan) // 2, len(plan)):
            cal = calibrate(experiments, profile)
            calibrated = dataclasses.replace(profile, thrust_map=cal.posterior)
            label = f"{cal.posterior.experiments} of {k + 1} experiments learnt"
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
