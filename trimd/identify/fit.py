"""Grey-box identification of the 6-DOF model, stage by stage (docs/method.md §5).

For one stage (:data:`trimd.identify.model.STAGES`) and one or more experiments:

0. an excitation check (:func:`trimd.identify.excitation.excitation_of`): per DOF of the
   stage, the spread of τ_i in the data against what the thrusters can give on that axis;
   a DOF below the threshold is not fitted (its velocity and angle are taken from the
   measurements, its parameters keep their given values and the fit says so);
1. a starting point that owes nothing to the profile's hydrodynamic values: the
   equation-error first pass (:func:`trimd.identify.start.equation_error_start`);
2. an output-error fit with a bounded Levenberg–Marquardt least squares
   (:func:`trimd.identify.solve.levenberg_marquardt`; physical bounds: added masses ≥ 0,
   inertia sums > 0, damping derivatives ≤ 0, thruster lag in [0, 1] s, lead over at most
   a thruster interval plus a grid step) of the simulation error over short segments,
   each started from the measured state (a stable simulation-error objective that
   tolerates a poor start), all experiments in one cost, each output weighted by the
   inverse of its spread and compared only at its own stream's samples
   (``Experiment.fresh``); the simulation steps over
   ``FitOptions.step_s`` (two samples at 50 Hz) and its Jacobian is one batched simulation
   of every perturbed parameter vector;
3. standard deviations and correlations from the Jacobian at the optimum
   (:func:`trimd.identify.solve.jacobian_covariance`; the simulation errors are
   correlated in time, so these are lower bounds); a parameter whose relative standard
   deviation exceeds ``max_rel_std`` is reported as not determined by the data, held at
   its estimate (never pulled back to the prior) and the fit repeated without it.

Validation of held-out experiments is :mod:`trimd.identify.validation`. The mass and the
restoring terms are held fixed: the profile's nominal vehicle, or a measured static
estimate (:class:`trimd.identify.model.Statics`).

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from trimd.core.errors import DataError, EstimationError
from trimd.core.profile import Profile
from trimd.core.types import FloatArray
from trimd.identify.data import Experiment
from trimd.identify.excitation import (
    excitation_of,
    not_excited_message,
)
from trimd.identify.model import (
    DVL_DOFS,
    HYDRO_NAMES,
    LAG,
    LEAD,
    STAGES,
    STATE_NAMES,
    Stage,
    Statics,
    observed,
    prior_values,
    statics_of_profile,
)
from trimd.identify.nodvl import with_estimated_velocity
from trimd.identify.problem import Problem
from trimd.identify.solve import jacobian_covariance, levenberg_marquardt
from trimd.identify.stage_fit import (
    NEEDS_DVL,
    NOT_DETERMINED,
    FitOptions,
    ParameterEstimate,
    StageFit,
)
from trimd.identify.start import LAG_GRID, equation_error_start

__all__ = ["NEEDS_DVL", "NOT_DETERMINED", "FitOptions", "ParameterEstimate", "StageFit",
           "fit_stage"]

#: A parameter whose standard deviation moves less than this share of its DOF's force or
#: moment counts as determined (negligible) even when its relative uncertainty is large.
MIN_SHARE = 0.02


def _bounds(name: str, problem: Problem) -> tuple[float, float]:
    if name == LAG:
        return 0.0, 1.0
    if name == LEAD:
        return 0.0, problem.lead_max
    if name.startswith("b_"):
        return -np.inf, np.inf
    k = HYDRO_NAMES.index(name)
    return (0.0, np.inf) if k < 6 else (-np.inf, 0.0)


def _step(name: str, value: float, problem: Problem) -> float:
    """Signed finite-difference step: relative, towards the interior of the bounds."""
    if name in (LAG, LEAD):
        upper = _bounds(name, problem)[1]
        return -1e-5 if value + 1e-5 > upper else 1e-5
    if name.startswith("b_"):
        return 1e-7
    k = HYDRO_NAMES.index(name)
    i = k % 6
    mass = value + (problem.mass if k < 3 else 0.0) if k < 6 else 0.0
    speed = max(float(np.sqrt(np.mean(problem.exo[..., i] ** 2))), 1e-3)
    typical = {0: mass, 1: 0.0, 2: 0.0}[k // 6]
    size = 1e-6 * max(abs(value), typical, 1e-6 / speed)
    return size if k < 6 else -size


def _weights(experiments: Sequence[Experiment], stage: Stage,
             given: Mapping[str, float]) -> FloatArray:
    x = np.concatenate([e.x for e in experiments])
    out = []
    for s in stage.outputs:
        name = STATE_NAMES[s]
        spread = float(np.std(x[:, s]))
        out.append(given.get(name, 1.0 / spread if spread > 0 else 1.0))
    return np.array(out)


def fit_stage(experiments: Sequence[Experiment], profile: Profile, stage: str,
              options: FitOptions | None = None, *, statics: Statics | None = None
              ) -> StageFit:
    """Identify the parameters of ``stage`` (module docstring).

    Only the DOFs the data excited (:func:`excitation_of`) are fitted. Without a DVL (an
    experiment whose ``dvl`` is False) surge and sway are nuisance states: simulated,
    never compared, their parameters fitted so that the unmeasured u, v that drive the
    coupling terms of the observed DOFs owe nothing to the prior, but noted
    :data:`NEEDS_DVL` and never reported as determined. That fit runs three times: with
    surge and sway held at the profile's values (u, v and w from its model:
    :func:`trimd.identify.nodvl.with_estimated_velocity`), with them free, and once more
    from u, v, w re-estimated with the fitted surge and sway. The parameters of DOFs that
    were not excited keep the profile's values, and :attr:`StageFit.warnings` says so.

    Parameters
    ----------
    experiments : open-loop records of this stage (same sample interval).
    profile : the thrusters (excitation check), and the prior of every hydrodynamic
        parameter the stage does not estimate; its mass and restoring terms unless
        ``statics`` is given.
    stage : uvr, uwq or uvwpqr.
    statics : mass and restoring terms held fixed (default: the profile's nominal
        vehicle, :func:`trimd.identify.model.statics_of_profile`).

    Raises
    ------
    EstimationError
        For an unknown stage, unknown fixed parameters, data that excites none of the
        stage's DOFs, or a fit that does not converge to finite values.
    DataError
        Without experiments, or experiments of different sample intervals or shorter
        than one segment.
    """
    opts = options or FitOptions()
    if stage not in STAGES:
        raise EstimationError(f"unknown stage '{stage}' (stages: {', '.join(STAGES)})")
    if not experiments:
        raise DataError("no experiment to fit")
    fixed_by = statics or statics_of_profile(profile)
    recorded = experiments
    experiments = with_estimated_velocity(
        recorded, prior_values(profile) | {LAG: opts.lag_s} | dict(opts.fixed),
        fixed_by.mass_kg, fixed_by.q_rest)
    excitation = excitation_of(experiments, profile, STAGES[stage], opts.min_excitation)
    missing = tuple(d for d in excitation if not d.excited)
    if len(missing) == len(excitation):
        raise EstimationError(f"{stage}: nothing to identify: "
                              + not_excited_message(stage, missing))
    dvl = all(e.dvl for e in experiments)
    blind = () if dvl else tuple(d for d in STAGES[stage].dofs if d in DVL_DOFS)
    excited = tuple(d.dof for d in excitation if d.excited)
    if not observed(STAGES[stage], dvl).restricted(excited).dofs:
        raise EstimationError(f"{stage}: nothing to identify: without a DVL the stage's "
                              "excited degrees of freedom are not observed")
    # without a DVL surge and sway are still simulated (never compared): their parameters
    # are nuisance parameters that carry the unmeasured u, v into the coupling terms
    st = STAGES[stage].restricted(excited)
    nuisance = frozenset(STAGES[stage].restricted(blind).free_names)
    problem, theta, free, prior, share = _setup(experiments, profile, st, opts, fixed_by)
    nfev = 0
    if nuisance:
        # first with surge and sway held at the profile's values (u, v from its model): a
        # start near the answer for the other parameters (from the equation-error start
        # alone the nuisance parameters can run off into a wrong minimum)
        for n in nuisance:
            theta[problem.index[n]] = prior[n]
        theta, *_, nfev = _fit(problem, theta, [i for i in free
                                                if problem.names[i] not in nuisance],
                               share, opts, stage, nuisance)
    theta, std_of, corr, rms, free, warnings, notes, more = _fit(problem, theta, free, share,
                                                                   opts, stage, nuisance)
    nfev += more
    if nuisance:
        # once more from u, v, w estimated with the fitted surge and sway
        fitted = dict(zip(problem.names, (float(v) for v in theta), strict=True))
        experiments = with_estimated_velocity(recorded, fitted, fixed_by.mass_kg,
                                              fixed_by.q_rest)
        problem, _, free, prior, share = _setup(experiments, profile, st, opts, fixed_by)
        theta = np.array([fitted[n] for n in problem.names])
        theta, std_of, corr, rms, free, warnings, notes, more = _fit(
            problem, theta, free, share, opts, stage, nuisance)
        nfev += more
    if missing:
        warnings.insert(0, f"{stage}: " + not_excited_message(stage, missing))
        for n in STAGES[stage].restricted(tuple(d.dof for d in missing)).free_names:
            if n not in opts.fixed:
                notes[n] = "not excited: profile's value"
    if blind:
        needs = STAGES[stage].restricted(blind).free_names
        warnings.insert(0, f"{stage}: no body velocity (DVL) in these logs: "
                        f"{', '.join(needs)} need a DVL (fitted only as the unmeasured "
                        "surge and sway motion, the profile's values kept)")
        for n in needs:
            if n not in opts.fixed:
                notes[n] = NEEDS_DVL
    params = tuple(ParameterEstimate(n, float(theta[k]), std_of.get(n, float("nan")),
                                     prior.get(n, 0.0), n in std_of, notes.get(n, ""))
                   for k, n in enumerate(problem.names))
    return StageFit(stage, params, corr, tuple(problem.names[i] for i in free), rms,
                    sum(len(e.t_s) for e in experiments), nfev, tuple(warnings), share,
                    excitation, fixed_by)


def _setup(experiments: Sequence[Experiment], profile: Profile, st: Stage,
           opts: FitOptions, statics: Statics
           ) -> tuple[Problem, FloatArray, list[int], dict[str, float], dict[str, float]]:
    """The problem, the starting vector (equation-error guess, fixed values), the indices
    of the free parameters, the prior of every parameter and the share scales."""
    h = experiments[0].h_s if experiments else 0.02
    problem = Problem(experiments, st, statics.mass_kg, statics.q_rest,
                      max(2, round(opts.segment_s / h)),
                      _weights(experiments, st, opts.weights),
                      stride=max(1, int(opts.step_s / h + 1e-9)))
    unknown = set(opts.fixed) - set(problem.names)
    if unknown:
        raise EstimationError(f"cannot fix unknown parameters {sorted(unknown)} "
                              f"(known: {', '.join(problem.names)})")
    prior = prior_values(profile) | {LAG: opts.lag_s, LEAD: 0.5 * problem.h}
    theta = np.array([prior.get(n, 0.0) for n in problem.names])
    fit_lag = opts.fit_lag and LAG not in opts.fixed
    lags = LAG_GRID if fit_lag else (opts.fixed.get(LAG, opts.lag_s),)
    guess, share = equation_error_start(experiments, st, statics, lags, problem.step)
    for name, v in guess.items():
        theta[problem.index[name]] = v
    free = [problem.index[n] for n in st.free_names if n not in opts.fixed]
    free += [i for i, n in enumerate(problem.names) if n.startswith("b_")
             and n not in opts.fixed]
    free += [problem.index[n] for n in (LAG, LEAD) if opts.fit_lag and n not in opts.fixed]
    for name, v in opts.fixed.items():
        theta[problem.index[name]] = v
    return problem, theta, free, prior, share


def _fit(problem: Problem, theta: FloatArray, free: list[int], share: Mapping[str, float],
         opts: FitOptions, stage: str, nuisance: frozenset[str] = frozenset()
         ) -> tuple[FloatArray, dict[str, float], FloatArray, float, list[int], list[str],
                    dict[str, str], int]:
    """Output-error fit, then hold the worst undetermined parameter at its estimate and
    repeat until every free one is determined (module docstring, step 3). Returns θ, the
    standard deviation of every parameter that was free in some run (the last run's for
    those still free, the one that judged it for the others), the correlations of the
    free parameters, the RMS residual, the free indices, warnings, notes per parameter and
    the simulations run."""
    warnings: list[str] = []
    notes: dict[str, str] = {}
    std_of: dict[str, float] = {}
    nfev = 0
    while True:
        theta, r, J, nf = _solve(problem, theta, free, opts.max_iter)
        nfev += nf
        std, corr = jacobian_covariance(J, r)
        rms = float(np.sqrt(np.mean(r * r)))
        std_of |= {problem.names[i]: float(std[j]) for j, i in enumerate(free)}
        j = _worst_undetermined(problem, theta, free, std, share, opts.max_rel_std,
                                nuisance)
        if j < 0:
            break
        i = free[j]
        name = problem.names[i]
        warnings.append(f"{stage}: {name} is {NOT_DETERMINED} (estimate {theta[i]:.4g} ± "
                        f"{std[j]:.2g}): held at that estimate, not used in the fragment")
        notes[name] = NOT_DETERMINED
        free.remove(i)
    if not np.all(np.isfinite(theta)):
        raise EstimationError(f"{stage}: the fit diverged")
    return theta, std_of, corr, rms, free, warnings, notes, nfev


def _worst_undetermined(problem: Problem, theta: FloatArray, free: Sequence[int],
                        std: FloatArray, share: Mapping[str, float], max_rel_std: float,
                        nuisance: frozenset[str]) -> int:
    """Position in ``free`` of the hydrodynamic parameter with the largest relative
    standard deviation, if that exceeds ``max_rel_std``, among those that are not
    negligible (their uncertainty moves at least :data:`MIN_SHARE` of their DOF's force at
    the typical motion) and not ``nuisance``; −1 if there is none."""
    candidates = []
    for j, i in enumerate(free):
        name = problem.names[i]
        sd = float(std[j]) if np.isfinite(std[j]) else np.inf
        if name not in HYDRO_NAMES or name in nuisance or sd * share[name] < MIN_SHARE:
            continue
        candidates.append((sd / abs(theta[i]) if theta[i] != 0 else np.inf, j))
    rel, j = max(candidates, default=(0.0, -1))
    return j if rel > max_rel_std else -1


def _solve(problem: Problem, theta: FloatArray, free: list[int], max_iter: int
           ) -> tuple[FloatArray, FloatArray, FloatArray, int]:
    """Bounded Levenberg–Marquardt over the ``free`` parameters
    (:func:`trimd.identify.solve.levenberg_marquardt`): θ, the residuals and Jacobian at
    the optimum, and the simulations run."""
    names = [problem.names[i] for i in free]
    lower, upper = np.array([_bounds(n, problem) for n in names]).T

    def full(x: FloatArray) -> FloatArray:
        t = theta.copy()
        t[free] = x
        return t

    def fun(x: FloatArray) -> FloatArray:
        return problem.residuals(full(x))

    def fun_jac(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        t = full(x)
        steps = np.array([_step(n, t[i], problem) for n, i in zip(names, free, strict=True)])
        return problem.jacobian(t, free, steps)

    x0 = np.clip(theta[free], lower, upper)
    if not np.all(np.isfinite(fun(x0))):
        raise EstimationError("the simulation diverges from the starting point: the data "
                              "do not determine a stable model (too little excitation?)")
    sol = levenberg_marquardt(fun_jac, fun, x0, lower, upper, max_iter=max_iter)
    return full(sol.x), sol.r, sol.J, sol.nfev
