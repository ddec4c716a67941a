"""Dynamic identification on the simulated vehicle, both shipped profiles: fit time per
stage on 10 min of 50 Hz data beside one forward simulation of the same data (the batched
simulation of all segments that one cost evaluation of the fit runs, and, labelled apart,
the sequential free run of the whole record that validation runs), the accuracy of every
parameter of docs/method.md §5 against the simulator's truth (beside the thesis's estimate for
the Sabertooth), and the validation NRMSE per output on 2 held-out minutes; each stage
ends with whether the issue's criteria hold (every parameter within 10 % of the truth or,
for a negligible one, its contribution below 10 % of its DOF's force or moment, its error
within 10 % of that force or moment; every validation NRMSE ≥ 90 %)."""

from __future__ import annotations

import asyncio
import math
import os
import time

import numpy as np

from bench.size import size
from trimd.app.experiment import run_experiment
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle
from trimd.identify.data import Experiment, experiments_from_samples
from trimd.identify.experiment import Excite
from trimd.identify.fit import FitOptions, StageFit, fit_stage
from trimd.identify.model import STAGES, prior_values, restoring_vector
from trimd.identify.problem import Problem
from trimd.identify.signals import design_signal
from trimd.identify.validation import validate

FIT_S = float(os.environ.get("TRIMD_BENCH_IDENT_S", size(600.0, 10.0)))
#: The held-out recording per stage [s].
VALIDATE_S = size(120.0, 2.0)
#: The fit's settings: the defaults; at the tiny size one iteration per least-squares run
#: and 2 s segments (half the sequential steps of each batched simulation).
FIT = size(FitOptions(), FitOptions(max_iter=1, segment_s=2.0))

#: docs/method.md §5: thesis estimates of the Sabertooth parameters (simulation).
THESIS = {"X_u": -117.8, "Y_v": -289.1, "X_u|u|": -280.7, "Y_v|v|": -979.3,
          "X_udot": 416.4, "Y_vdot": 307.5, "N_r": -4356, "N_r|r|": -2417,
          "I_z+N_rdot": 1534.3, "Z_w": -0.91, "Z_w|w|": -5320, "M_q": -245.5,
          "M_q|q|": -105040, "Z_wdot": 828.7, "I_y+M_qdot": 3314.8, "K_p": -1065,
          "K_p|p|": -1054, "I_x+K_pdot": 376.2}
#: docs/method.md §5: which stage the thesis assigns each parameter to.
TABLE = {"uvr": ("X_u", "Y_v", "X_u|u|", "Y_v|v|", "X_udot", "Y_vdot", "N_r", "N_r|r|",
                 "I_z+N_rdot"),
         "uwq": ("Z_w", "Z_w|w|", "Z_wdot", "M_q", "M_q|q|", "I_y+M_qdot"),
         "uvwpqr": ("K_p", "K_p|p|", "I_x+K_pdot")}
THESIS_NRMSE = {"uvr": "u 95, v 87, r 77", "uwq": "u 57, w 69, q 84",
                "uvwpqr": "u 52, v 41, w -25, p 82, q 81, r 80"}


def _record(profile: Profile, stage: str, duration: float, seed: int) -> list[Experiment]:
    sig = design_signal(profile, stage, duration_s=duration, seed=seed,
                        depth_excursion_m=50.0)
    vehicle = SimVehicle(profile, SimConfig(seed=seed, dvl=True, depth_m=100.0,
                                            attitude_hz=50.0, thrusters_hz=50.0,
                                            velocity_hz=50.0, depth_hz=50.0))
    excite = Excite(profile, sig, confirmed=True, depth_excursion_m=50.0)
    result, samples = asyncio.run(run_experiment(SimLink(vehicle), profile, excite))
    if not result.phase.final or result.cause:
        raise RuntimeError(f"excitation failed: {result.reason}")
    return experiments_from_samples(samples, profile, label=f"{stage} seed {seed}")


def _forward_time(fit: StageFit, experiments: list[Experiment], profile: Profile,
                  stage: str) -> float:
    """Seconds of one cost evaluation: the batched simulation of every segment of
    ``experiments`` with the fitted parameters (what each iteration of the fit runs)."""
    st = STAGES[stage]
    problem = Problem(experiments, st, profile.mass_kg, restoring_vector(profile),
                      max(2, round(FitOptions().segment_s / experiments[0].h_s)),
                      np.ones(len(st.outputs)))
    theta = np.array([fit[n].value for n in problem.names])
    t0 = time.perf_counter()
    problem.residuals(theta)
    return time.perf_counter() - t0


def _stage(profile: Profile, stage: str) -> tuple[bool, float, float]:
    """Fit, report and judge one stage: whether the issue's criteria hold, the fit time
    and the time of one forward simulation of the same data [s]."""
    fit_data = _record(profile, stage, FIT_S, 11)
    val_data = _record(profile, stage, VALIDATE_S, 12)
    t0 = time.perf_counter()
    fit = fit_stage(fit_data, profile, stage, FIT)
    t_fit = time.perf_counter() - t0
    t_sim = _forward_time(fit, fit_data, profile, stage)
    t0 = time.perf_counter()
    validate(fit.values(), fit_data, profile, stage)
    t_free = time.perf_counter() - t0
    n = sum(len(e.t_s) for e in fit_data)
    print(f"  {stage}: fit {t_fit:6.1f} s on {n * fit_data[0].h_s / 60:.1f} min "
          f"({fit.nfev} simulations); one forward simulation of the same data (batched "
          f"segments, one cost evaluation) {t_sim:5.2f} s, ratio {t_fit / t_sim:5.1f}; "
          f"sequential free run of the whole record {t_free:5.2f} s")
    truth = prior_values(profile)
    sabertooth = profile.name.startswith("sabertooth")
    shown = TABLE[stage] if sabertooth else STAGES[stage].free_names
    ok = True
    for name in shown:
        p = fit[name]
        tv = truth[name]
        # a DOF the record did not excite has no share scale: judged by its error alone
        scale = fit.share.get(name, math.nan)
        share = abs(p.value - tv) * scale
        # the share rule judges only a negligible coefficient: its whole contribution is
        # below 10 % of the DOF's force or moment (a zero one included)
        negligible = abs(tv) * scale < 0.1
        good = bool(share <= 0.1 if negligible else abs(p.value - tv) <= 0.1 * abs(tv))
        ok &= good
        err = f"{100 * (p.value - tv) / tv:+7.2f} %" if tv else "   (zero)"
        thesis = f"  thesis {THESIS[name]:>9.5g}" if sabertooth else ""
        print(f"    {name:<12} truth {tv:>10.5g}  estimate {p.value:>10.5g} ± "
              f"{p.std:8.2g}  error {err}  share of DOF {100 * share:5.2f} %"
              f"{'' if good else '  FAIL'}{thesis} {p.note}")
    for w in fit.warnings:
        print(f"    warning: {w}")
    for v in validate(fit.values(), val_data, profile, stage):
        fits = ", ".join(f"{o} {x:.1f}" for o, x in zip(v.outputs, v.nrmse, strict=True))
        ok &= min(v.nrmse) >= 90.0
        print(f"    validation NRMSE %: {fits}   (thesis: {THESIS_NRMSE[stage]})")
    print(f"    criteria (10 %, or share ≤ 10 % for a negligible one; NRMSE ≥ 90 %): "
          f"{'met' if ok else 'NOT met'}")
    return ok, t_fit, t_sim


def main() -> None:
    for name in size(("sabertooth-dh2", "bluerov2-heavy"), ("sabertooth-dh2",)):
        profile = load_profile(name)
        print(f"{name}: {FIT_S:g} s of 50 Hz data per stage, default noise, DVL on")
        met, t_fit, t_sim = [], 0.0, 0.0
        for stage in STAGES:
            try:
                ok, fit_s, sim_s = _stage(profile, stage)
            except RuntimeError as exc:   # an experiment the envelope stopped
                print(f"  {stage}: {exc}")
                ok, fit_s, sim_s = False, float("nan"), float("nan")
            met.append(ok)
            t_fit, t_sim = t_fit + fit_s, t_sim + sim_s
        print(f"  {name}: criteria met in {sum(met)} of {len(met)} stages; the three stages "
              f"fitted in {t_fit:.1f} s (target < 30 s), one forward simulation of the "
              f"same data {t_sim:.2f} s")


if __name__ == "__main__":
    main()
