"""A probe of a thrust-map model trimd does not use yet (issue 24, docs/method.md §7, "What
a calibration could at best give"): the curves fitted nonlinearly to level calibration
experiments, each thruster's curve scaled by its gains and its ESC band shifted by its
offsets, then the trim with the fitted curves.

§7's calibration is linear in the thrust map's errors and takes a band's factor as a
magnitude, which biases its update near the band: four experiments leave the Heavy's
W − B worse than one. Here each hold's per-thruster PWM samples are kept (a recorder of
the session's samples, zero-order held onto the hold's steady samples as the procedure
holds them) and the errors z (units of the prior σ, :mod:`trimd.core.systematics`' order:
gains forward, reverse, band edges negative, positive) are fitted by
``scipy.optimize.least_squares`` to every experiment's change of Z, K, M, whitened by its
covariance R (:func:`trimd.core.calibration.experiment_rows`), with the prior z ~ N(0, I)
as rows of its own. Per seed and case (``truth=perturbed``, realistic disturbances): the
trim with the profile alone, then with the curves fitted to the first half and to all of
:data:`PLAN`'s experiments (a weight and a float of the same size at each corner, each
between two level holds of ``collect_max_s``), judged by the TRUE q.

``TRIMD_FIT_SEEDS`` (default 16), ``TRIMD_FIT_CASES``, ``TRIMD_COVERAGE_PROCESSES`` as in
:mod:`bench.bench_calibration`. One seed takes ≈ 40 s of one core (the Heavy): three trims
and sixteen level holds.
"""

from __future__ import annotations

import asyncio
import dataclasses

import numpy as np
from scipy.optimize import least_squares

from bench.bench_calibration import NOISE, OPTIONS, TARGETS, judged_trim, known_weight
from bench.bench_safety import Stamps
from bench.bench_sim_coverage import CASES, Run, picked, rms_errors, run_seeds, seeding
from bench.bench_thrust_map_ceiling import FLOAT_PCT
from bench.size import size, sized_profile
from trimd.app.calibrate import KnownWeight, calibration_experiment, level_hold_procedure
from trimd.app.connect import open_link
from trimd.app.session import Session
from trimd.core.calibration import ballast_change, experiment_rows
from trimd.core.effort import MAX_THRUSTER_AGE_S
from trimd.core.estimate import HoldSamples
from trimd.core.model import restoring_matrix, thrust_configuration, thrust_from_pwm
from trimd.core.profile import Profile, Thruster
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Sample, Thrusters
from trimd.core.systematics import BAND_SIGMA_SHARE
from trimd.core.types import FloatArray
from trimd.drivers.sim.truth import TruthOffset, true_thrusters

#: profile → the experiments: (slot, +1 the known weight of
#: :data:`bench.bench_calibration.WEIGHTS`, −1 a float of the same size).
PLAN = {"bluerov2-heavy": (("W-front-stbd", 1), ("W-aft-port", -1), ("W-front-port", 1),
                           ("W-aft-stbd", -1), ("W-front-stbd", -1), ("W-aft-port", 1),
                           ("W-front-port", -1), ("W-aft-stbd", 1)),
        "sabertooth-dh2": (("FrontSB", 1), ("AftP", -1), ("FrontP", 1), ("AftSB", -1),
                           ("FrontSB", -1), ("AftP", 1), ("FrontP", -1), ("AftSB", 1))}


class Outputs(Stamps):
    """A session recorder that keeps the thruster outputs it sees (and records nothing)."""

    def __init__(self) -> None:
        super().__init__()
        self.t: list[float] = []
        self.pwm: list[tuple[float, ...]] = []

    def sample(self, sample: Sample) -> Sample:
        if isinstance(sample, Thrusters):
            self.t.append(sample.t_s)
            self.pwm.append(sample.pwm_us)
        return super().sample(sample)

    def held(self, hold: HoldSamples) -> FloatArray:
        """The outputs held onto each of ``hold``'s samples, shape (N, n) [µs]."""
        k = np.searchsorted(self.t, hold.t_s, side="right") - 1
        assert np.all(k >= 0) and np.all(hold.t_s - np.asarray(self.t)[k] <= MAX_THRUSTER_AGE_S)
        return np.asarray(self.pwm, float)[k]


def level_hold(profile: Profile, url: str) -> tuple[HoldSamples, FloatArray]:
    """One level hold on ``url``: its samples and the PWM held onto them."""
    async def go() -> tuple[HoldSamples, FloatArray]:
        link, outputs = await open_link(url, profile), Outputs()
        try:
            result = await Session(link, profile, recorder=outputs, presenters=[],
                                   procedure=level_hold_procedure(profile, confirmed=True),
                                   wall_clock=False).run()
        finally:
            await link.close()
        assert result.verification is not None, result.reason
        return result.verification, outputs.held(result.verification)
    return asyncio.run(go())


def fitted_thrusters(profile: Profile, z: FloatArray) -> tuple[Thruster, ...]:
    """The profile's thrusters with each curve scaled by 1 + σ_gain·z (forward, reverse)
    and its band edges moved by σ_band·z [µs] (z in :mod:`trimd.core.systematics`' order),
    as the simulator makes its true curves (:func:`trimd.drivers.sim.truth.true_thrusters`)."""
    forward, reverse, low, high = np.split(np.asarray(z, float), 4)
    gain = np.array([t.curve.uncertainty_pct / 100 for t in profile.thrusters])
    band = np.array([t.curve.deadband_margin_us * BAND_SIGMA_SHARE for t in profile.thrusters])
    return true_thrusters(profile, TruthOffset(
        1.0, (0.0, 0.0, 0.0),
        tuple(zip(map(float, 1 + gain * forward), map(float, 1 + gain * reverse), strict=True)),
        tuple(zip(map(float, band * low), map(float, band * high), strict=True))))


@dataclasses.dataclass(frozen=True)
class Change:
    """One experiment as the fit needs it: the change of τ on its rows that the known
    ballast change makes [N, N·m], R's inverse lower factor, the rows, and the PWM of the
    hold before and after [µs]."""

    target: FloatArray
    whiten: FloatArray
    rows: FloatArray
    before: FloatArray
    after: FloatArray


def change_of(profile: Profile, before: tuple[HoldSamples, FloatArray],
              after: tuple[HoldSamples, FloatArray], weight: KnownWeight) -> Change:
    """The experiment of ``before`` and ``after`` hanging ``weight``."""
    exp = calibration_experiment(before[0], after[0], profile, weight)
    _, _, R, rows = experiment_rows(exp, profile)
    q1 = exp.q_before
    q2 = q1 + ballast_change(profile, exp.change)[0]
    target = (restoring_matrix(exp.after.phi_rad, exp.after.theta_rad)[rows] @ q2
              - restoring_matrix(exp.before.phi_rad, exp.before.theta_rad)[rows] @ q1)
    return Change(target, np.linalg.inv(np.linalg.cholesky(R)), rows, before[1], after[1])


def fit(profile: Profile, changes: list[Change]) -> FloatArray:
    """z fitted to ``changes`` with the prior N(0, I) (module docstring)."""
    T = thrust_configuration(profile.thrusters)
    v = profile.nominal_voltage_V

    def mean_thrust(ts: tuple[Thruster, ...], pwm: FloatArray) -> FloatArray:
        return np.array([thrust_from_pwm(t.curve, pwm[:, i], v).mean()
                         for i, t in enumerate(ts)])

    def residuals(z: FloatArray) -> FloatArray:
        ts = fitted_thrusters(profile, z)
        return np.concatenate([z, *(c.whiten @ (T[c.rows] @ (mean_thrust(ts, c.after)
                                                             - mean_thrust(ts, c.before))
                                                - c.target) for c in changes)])

    x: FloatArray = least_squares(residuals, np.zeros(4 * len(profile.thrusters)),
                                  diff_step=1e-3).x
    return x


def run(name: str, payload: str, seed: int, options: str) -> tuple[tuple[str, Run], ...]:
    """The trims of ``seed``, each with its label (module docstring); at the tiny size one
    experiment."""
    profile = sized_profile(load_profile(name))
    weight = known_weight(profile)
    runs = [("profile alone", judged_trim(profile, payload, seed, options)[0])]
    plan = PLAN[name][:size(len(PLAN[name]), 1)]
    changes = []
    for k, (slot, sign) in enumerate(plan):
        x, y, z = profile.slot(slot).position_m
        kg = sign * weight.kg

        def url(extra: str, dive: int) -> str:
            return (f"sim:payload={payload}{extra},seed={seed + dive * NOISE},"
                    f"truth_seed={seed},{options}")
        before = level_hold(profile, url("", 2 * k + 1))
        after = level_hold(profile, url(f"+{kg:.6f}@{x},{y},{z}", 2 * k + 2))
        changes.append(change_of(profile, before, after, KnownWeight(
            kg, slot, weight.uncertainty_pct if sign > 0 else FLOAT_PCT)))
        if k + 1 in (len(plan) // 2, len(plan)):
            fitted = dataclasses.replace(profile, thrusters=fitted_thrusters(
                profile, fit(profile, changes)))
            runs.append((f"fitted to {k + 1} experiments", judged_trim(
                profile, payload, seed, options, lambda _v, p=fitted: p)[0]))
    return tuple(runs)


def main() -> None:
    cfg = seeding("FIT", size(16, 1), OPTIONS)
    for name, payload in picked(size(CASES, CASES[:1]), cfg.wanted):
        runs, wall = run_seeds(run, name, payload, cfg.seeds, cfg.options, cfg.processes)
        profile = load_profile(name)
        print(f"{name}, {payload}, sim:{cfg.options}: {cfg.seeds} seeds, {wall:.1f} s wall "
              "per seed; RMS error of W − B [N], x, y, z net [mm-equivalent]")
        for k, (label, _) in enumerate(runs[0]):
            rms = rms_errors([r[k][1] for r in runs], profile.weight_N)
            print(f"    {label:28s}" + " ".join(f"{v:8.3f}" for v in rms))
        target_wb, target_m = TARGETS[profile.name]
        wb = "—" if target_wb is None else f"{target_wb:.3g} N"
        print(f"    issue 24's targets: W − B {wb}, each net moment {target_m:.3g} mm-equivalent")
