"""Monte Carlo of the staged identification over vehicles the prior does not describe.

Per shipped profile (the prior), ``TRIMD_BENCH_MC_N`` random vehicles (default 10, so 20
over both profiles) whose every inertia sum, added mass and linear and quadratic damping
coefficient is the profile's times a random factor in [0.5, 1.5] and whose buoyancy is
the profile's times one in [0.99, 1.01] (:func:`trimd.identify.vehicles.perturbed`); for
each, the three stages' excitation designed from the prior, ``TRIMD_BENCH_IDENT_S``
seconds each (default 600) of data at the stream rates ``trimd excite`` asks for
(``TRIMD_BENCH_MC_RATES``: :data:`RATES`) with default noise and a DVL, inside ``trimd
excite``'s default depth envelope (:data:`ENVELOPE_M`, and the profile's tilt limit),
fitted with the staged procedure from the prior
(:func:`trimd.identify.staged.fit_stages`) and validated on 2 held-out minutes per stage;
then the same recordings without their body velocity (no DVL), judged on heave, roll,
pitch and yaw. Printed: per parameter the distribution of the relative error, per DOF the
distribution of the damping force error at 0.15 and 0.4 m/s or rad/s, the worst held-out
NRMSE of the excited outputs, and the share of vehicles that meet the issue's targets
(every inertia sum within 5 %, every damping force within 10 %, every excited NRMSE
≥ 90 %; target: 95 % of the vehicles), and how the experiments ended: complete,
stopped early at the edge of their envelope (the data up to the stop fitted all the same)
or aborted by the guard; target: every experiment of a vehicle complete in 95 % of the
vehicles. The experiment reads no DVL (its holds use the attitude and the depth sensor),
so a run without one is the same run: the fit without a DVL drops the body velocity from
the same recordings.

A damping force is judged within the rates the experiments reached: at the lesser of the
target speed and the 99th percentile of |ν_i| in the fitted recordings (the Sabertooth
pitches and yaws at 0.05–0.09 rad/s with its thrusters' authority and tilt limits; its
damping at 0.4 rad/s is an extrapolation no experiment of it can check). The report says
which DOFs were judged below the target speed and at what rate.

``TRIMD_BENCH_MC_PROFILES`` (comma-separated, default both) picks the priors."""

from __future__ import annotations

import asyncio
import os
import time
from collections.abc import Sequence

import numpy as np

from bench.size import size
from trimd.app.experiment import run_experiment
from trimd.core.events import Phase
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Sample, Velocity
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle
from trimd.identify.data import Experiment, experiments_from_samples
from trimd.identify.envelope import STOP_EARLY
from trimd.identify.experiment import STREAM_HZ, Excite
from trimd.identify.fit import FitOptions
from trimd.identify.model import (
    DVL_DOFS,
    HYDRO_NAMES,
    STAGES,
    prior_values,
    statics_of_profile,
)
from trimd.identify.report import best_values
from trimd.identify.signals import design_signal
from trimd.identify.staged import fit_stages
from trimd.identify.validation import validate
from trimd.identify.vehicles import damping_force, perturbed, rates_reached

N = int(os.environ.get("TRIMD_BENCH_MC_N", size(10, 1)))
#: Stream rates of the recordings: "excite" (the default) what ``trimd excite`` asks of the
#: simulator, attitude, thruster outputs and depth at
#: :data:`trimd.identify.experiment.STREAM_HZ` (50 Hz) and the DVL at its own 5 Hz;
#: "50" every stream at 50 Hz, the DVL too; "sim" the simulator's default rates (attitude
#: 20 Hz, thrusters 10 Hz, DVL and depth 5 Hz: a vehicle that ignores the request, or a
#: ground station's log).
RATES = os.environ.get("TRIMD_BENCH_MC_RATES", "excite")
#: per RATES value: the SimConfig stream rates, and the words for the report
_RATES: dict[str, tuple[dict[str, float], str]] = {
    "excite": (dict(attitude_hz=STREAM_HZ, thrusters_hz=STREAM_HZ, depth_hz=STREAM_HZ),
               f"attitude, thrusters and depth at {STREAM_HZ:g} Hz (trimd excite's request), "
               "DVL at 5 Hz"),
    "50": (dict(attitude_hz=50.0, thrusters_hz=50.0, velocity_hz=50.0, depth_hz=50.0),
           "every stream at 50 Hz"),
    "sim": ({}, "the simulator's default stream rates (attitude 20 Hz, thrusters 10 Hz, DVL "
                "and depth 5 Hz)"),
}
FIT_S = float(os.environ.get("TRIMD_BENCH_IDENT_S", size(600.0, 10.0)))
#: The depth envelope of every experiment [m]: ``trimd excite``'s default.
ENVELOPE_M = 5.0
#: The buoyancy of a random vehicle is the prior's times a factor in 1 ± this.
BUOYANCY_SPREAD = 0.01
#: The held-out recording per stage [s].
VALIDATE_S = size(120.0, 2.0)
#: The fit's settings: the defaults; at the tiny size one iteration per least-squares run
#: and 2 s segments (half the sequential steps of each batched simulation).
FIT = size(FitOptions(), FitOptions(max_iter=1, segment_s=2.0))
SPEEDS = (0.15, 0.4)
PROFILES = os.environ.get("TRIMD_BENCH_MC_PROFILES",
                          size("bluerov2-heavy,sabertooth-dh2", "sabertooth-dh2")).split(",")
DOFS = ("surge", "sway", "heave", "roll", "pitch", "yaw")


def record(truth: Profile, prior: Profile, stage: str, duration: float, seed: int,
           rates: str = RATES) -> tuple[list[Sample], str]:
    """One excitation of ``stage`` designed from ``prior``, flown by ``truth`` on the
    simulator (DVL on, default noise) at the stream ``rates`` (:data:`RATES`) inside the
    :data:`ENVELOPE_M` depth envelope: every sample, and how it ended ("complete",
    "stopped early" or "aborted: …")."""
    sig = design_signal(prior, stage, duration_s=duration, seed=seed,
                        depth_excursion_m=ENVELOPE_M)
    config = SimConfig(seed=seed, dvl=True, depth_m=100.0, **_RATES[rates][0])
    vehicle = SimVehicle(truth, config)
    excite = Excite(prior, sig, confirmed=True, depth_excursion_m=ENVELOPE_M, stage=stage)
    result, samples = asyncio.run(run_experiment(SimLink(vehicle), prior, excite))
    if result.phase is Phase.DONE:
        return samples, "stopped early" if result.reason.startswith(STOP_EARLY) else "complete"
    return samples, f"aborted: {result.reason}"


def _judge(truth: Profile, prior: Profile, recordings: dict[str, tuple[list[Sample],
                                                                        list[Sample]]],
           dvl: bool) -> tuple[dict[str, float], dict[tuple[int, float], float], float, float,
                               tuple[float, ...]]:
    """Fit and validate one vehicle, its mass and restoring terms held at its own (as
    ``--estimate`` with its trim's static estimate holds them; the prior's would be 1 % of
    the buoyancy off): relative error per determined hydrodynamic parameter
    (the inertia sums as m + added mass for surge, sway and heave), damping force error
    per (DOF, speed) at the lesser of the speed and the rate reached
    (:func:`trimd.identify.vehicles.rates_reached` of the fitted recordings, which carry
    the DVL's samples), the worst excited NRMSE [%], the fit time [s] and the rates
    reached."""
    def exps(samples: list[Sample]) -> list[Experiment]:
        kept = samples if dvl else [s for s in samples if not isinstance(s, Velocity)]
        return experiments_from_samples(kept, prior)

    statics = statics_of_profile(truth)   # as the vehicle's trim measures them
    t0 = time.perf_counter()
    fits = fit_stages({st: exps(fit) for st, (fit, _) in recordings.items()}, prior, FIT,
                      statics=statics)
    t_fit = time.perf_counter() - t0
    values = prior_values(prior) | best_values(fits)   # as `trimd identify` writes them
    true = prior_values(truth)
    dofs = range(6) if dvl else [d for d in range(6) if d not in DVL_DOFS]
    errors: dict[str, float] = {}
    for d in dofs:
        rigid = truth.mass_kg if d < 3 else 0.0
        errors[HYDRO_NAMES[d]] = (values[HYDRO_NAMES[d]] + rigid) / (true[HYDRO_NAMES[d]]
                                                                     + rigid) - 1
        for k in (6, 12):
            if true[HYDRO_NAMES[k + d]]:
                errors[HYDRO_NAMES[k + d]] = values[HYDRO_NAMES[k + d]] / true[
                    HYDRO_NAMES[k + d]] - 1
    reach = rates_reached(s for fit, _ in recordings.values() for s in fit)
    forces = {(d, v): damping_force(values, d, min(v, reach[d]))
              / damping_force(true, d, min(v, reach[d])) - 1 for d in dofs for v in SPEEDS}
    worst = 100.0
    for f in fits:
        for val in validate(f.values(), exps(recordings[f.stage][1]), prior, f.stage,
                            statics=statics):
            w = val.worst()
            worst = min(worst, w if w is not None else worst)
    return errors, forces, worst, t_fit, reach


def _quantiles(x: Sequence[float]) -> str:
    a = 100 * np.abs(np.asarray(x))
    return (f"median {np.median(a):5.2f} %  90th {np.percentile(a, 90):5.2f} %  "
            f"max {a.max():6.2f} %")


def _report(label: str, results: list[tuple[dict[str, float], dict[tuple[int, float], float],
                                            float, float, tuple[float, ...]]]) -> None:
    print(f"  {label}: {len(results)} vehicles, fit time per vehicle (three stages) "
          f"median {np.median([r[3] for r in results]):.1f} s")
    names = [n for n in HYDRO_NAMES if n in results[0][0]]
    for n in names:
        errs = [r[0][n] for r in results if n in r[0]]
        sum_note = " (inertia sum)" if n in HYDRO_NAMES[:6] else ""
        print(f"    {n:<12} |error| {_quantiles(errs)}{sum_note}")
    for d, v in results[0][1]:
        below = [r[4][d] for r in results if r[4][d] < v]
        note = (f"  (judged at the rate reached in {len(below)} vehicles: "
                f"{min(below):.3g}–{max(below):.3g})" if below else "")
        print(f"    damping force {DOFS[d]:<5} at {v:.2f}: |error| "
              f"{_quantiles([r[1][(d, v)] for r in results])}{note}")
    worst = [r[2] for r in results]
    print(f"    worst excited held-out NRMSE per vehicle: min {min(worst):.1f} %, median "
          f"{np.median(worst):.1f} %")
    ok = [all(abs(e) <= 0.05 for n, e in r[0].items() if n in HYDRO_NAMES[:6])
          and all(abs(e) <= 0.10 for e in r[1].values()) and r[2] >= 90.0 for r in results]
    print(f"    targets (inertia sums 5 %, damping forces 10 %, NRMSE ≥ 90 %) met in "
          f"{sum(ok)} of {len(ok)} vehicles ({100 * sum(ok) / len(ok):.0f} %; target 95 %)")


def main() -> None:
    for name in PROFILES:
        prior = load_profile(name)
        print(f"{name} as prior: {N} vehicles ×[0.5, 1.5] per hydrodynamic parameter, "
              f"buoyancy ×[{1 - BUOYANCY_SPREAD:g}, {1 + BUOYANCY_SPREAD:g}], {FIT_S:g} s per "
              f"stage inside a ±{ENVELOPE_M:g} m depth envelope, " + _RATES[RATES][1]
              + ", default noise")
        with_dvl, without, ends = [], [], []
        for k in range(N):
            truth = perturbed(prior, np.random.default_rng(1000 + k), name=f"{name}-{k}",
                              buoyancy_spread=BUOYANCY_SPREAD)
            recordings, how = {}, []
            for j, st in enumerate(STAGES):
                (fit, a), (held, b) = (record(truth, prior, st, FIT_S, 10 * k + j),
                                       record(truth, prior, st, VALIDATE_S, 10 * k + j + 5))
                recordings[st] = (fit, held)
                how += [f"{st} {a}", f"{st} held-out {b}"]
            ends.append(how)
            with_dvl.append(_judge(truth, prior, recordings, True))
            without.append(_judge(truth, prior, recordings, False))
            odd = [h for h in how if not h.endswith(" complete")]
            print(f"  vehicle {k} (B ×{truth.buoyancy_N / prior.buoyancy_N:.4f}): worst NRMSE "
                  f"{with_dvl[-1][2]:.1f} % with DVL, {without[-1][2]:.1f} % without; "
                  f"experiments {'all complete' if not odd else '; '.join(odd)}", flush=True)
        _report("with DVL", with_dvl)
        _report("without DVL (heave, roll, pitch, yaw)", without)
        _ends(ends)


def _ends(ends: list[list[str]]) -> None:
    """How the experiments ended, per experiment and per vehicle."""
    flat = [h for how in ends for h in how]
    early = sum("stopped early" in h for h in flat)
    aborted = sum("aborted" in h for h in flat)
    whole = sum(all(h.endswith(" complete") for h in how) for how in ends)
    print(f"  experiments: {len(flat) - early - aborted} complete, {early} stopped early, "
          f"{aborted} aborted by the envelope; vehicles whose every experiment completed: "
          f"{whole} of {len(ends)} ({100 * whole / max(len(ends), 1):.0f} %; target 95 %)")


if __name__ == "__main__":
    main()
