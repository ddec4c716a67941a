"""Grey-box identification of the 6-DOF model, stage by stage (method.md §5).

For one stage (:data:`trimd.identify_model.STAGES`) and one or more experiments:

1. a starting point that owes nothing to the profile's hydrodynamic values: per excited
   DOF, a non-negative least-squares equation-error fit of M_i·ν̇_i − D_i·ν_i −
   D_i|i|·|ν_i|·ν_i = τ_i − g_i(η) on smoothed derivatives of the measurements;
2. an output-error fit with :func:`scipy.optimize.least_squares` (trust-region reflective,
   physical bounds: added masses ≥ 0, inertia sums > 0, damping derivatives ≤ 0, thruster
   lag in [0, 1] s) of the simulation error over short segments, each started from the
   measured state (a stable simulation-error objective that tolerates a poor start), all
   experiments in one cost, each output weighted by the inverse of its spread;
3. standard deviations and correlations from the Jacobian at the optimum
   (cov = s²·(JᵀJ)⁻¹, s² the residual variance; the simulation errors are correlated in
   time, so these are lower bounds), and a parameter whose relative standard deviation
   exceeds ``max_rel_std`` is reported, fixed at the profile's value and the fit repeated;
4. :func:`validate`: a free-run simulation of held-out experiments and the normalised RMSE
   fit 100·(1 − ‖y − ŷ‖/‖y − mean(y)‖) % per output.

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares, nnls
from scipy.signal import savgol_filter

from trimd.errors import EstimationError
from trimd.identify_data import Experiment
from trimd.identify_model import (
    HYDRO_NAMES,
    LAG,
    LEAD,
    STAGES,
    STATE_NAMES,
    Stage,
    lagged_thrust,
    prior_values,
    restoring_vector,
)
from trimd.identify_problem import Problem
from trimd.model import restoring_matrix
from trimd.profile import Profile

__all__ = ["FitOptions", "ParameterEstimate", "StageFit", "Validation", "fit_stage",
           "nrmse", "validate"]

FloatArray = NDArray[np.float64]
#: A parameter whose standard deviation moves less than this share of its DOF's force or
#: moment counts as determined (negligible) even when its relative uncertainty is large.
MIN_SHARE = 0.02


@dataclass(frozen=True)
class FitOptions:
    """Settings of :func:`fit_stage`.

    Attributes
    ----------
    segment_s : simulation horizon of each segment [s].
    weights : per output name (u, v, w, p, q, r, phi, theta) the weight of its error;
        outputs not named get 1/std of the measured output.
    lag_s : thruster lag [s] when it is not fitted.
    fit_lag : estimate the thruster lag (starting from the best of :data:`LAG_GRID`) and
        the lead of the thruster record (starting from half a sample interval).
    fixed : parameters held at the given value (named as in the report).
    max_rel_std : relative standard deviation above which a parameter counts as not
        determined by the data.
    max_nfev : iterations (function evaluations) per least-squares run.
    """

    segment_s: float = 4.0
    weights: Mapping[str, float] = field(default_factory=dict)
    lag_s: float = 0.05
    fit_lag: bool = True
    fixed: Mapping[str, float] = field(default_factory=dict)
    max_rel_std: float = 0.3
    max_nfev: int = 60


@dataclass(frozen=True)
class ParameterEstimate:
    """One named parameter: estimate, standard deviation (NaN when fixed), the profile's
    value (prior) and whether it was estimated."""

    name: str
    value: float
    std: float
    prior: float
    free: bool
    note: str = ""


@dataclass(frozen=True, eq=False)
class StageFit:
    """Result of :func:`fit_stage`.

    Attributes
    ----------
    stage : stage name.
    parameters : every hydrodynamic parameter and the lag (fixed ones with their value),
        then the bias parameters.
    correlation : correlation matrix of the free parameters, in ``free_names`` order.
    free_names : names of the estimated parameters.
    rms_residual : RMS of the weighted residuals at the optimum.
    n_samples : samples used (all experiments).
    nfev : simulations of the least-squares runs (Jacobians count one each).
    warnings : parameters the data did not determine, and other caveats.
    share : per estimated hydrodynamic parameter, the share of its DOF's force or moment
        per unit change of the parameter at the experiments' typical motion (|δ|·share is
        the share a change δ makes: the judge of a negligible coefficient).
    """

    stage: str
    parameters: tuple[ParameterEstimate, ...]
    correlation: FloatArray
    free_names: tuple[str, ...]
    rms_residual: float
    n_samples: int
    nfev: int
    warnings: tuple[str, ...]
    share: Mapping[str, float] = field(default_factory=dict)

    def values(self) -> dict[str, float]:
        return {p.name: p.value for p in self.parameters}

    def __getitem__(self, name: str) -> ParameterEstimate:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)


@dataclass(frozen=True, eq=False)
class Validation:
    """Free-run simulation of one experiment: NRMSE [%] per output, and the series."""

    label: str
    outputs: tuple[str, ...]
    nrmse: tuple[float, ...]
    t_s: FloatArray
    measured: FloatArray
    simulated: FloatArray


def nrmse(y: FloatArray, y_hat: FloatArray) -> FloatArray:
    """Normalised RMSE fit 100·(1 − ‖y − ŷ‖/‖y − mean(y)‖) [%] per column (MATLAB
    compare()); 100 is perfect, negative is worse than the mean.

    Examples
    --------
    >>> float(nrmse(np.array([1.0, 2.0, 3.0]), np.array([1.0, 2.0, 3.0])))
    100.0
    >>> float(nrmse(np.array([1.0, 2.0, 3.0]), np.array([2.0, 2.0, 2.0])))
    0.0
    """
    y, y_hat = np.asarray(y, float), np.asarray(y_hat, float)
    num = np.linalg.norm(y - y_hat, axis=0)
    den = np.linalg.norm(y - y.mean(axis=0), axis=0)
    out: FloatArray = 100.0 * (1.0 - num / np.where(den > 0, den, np.nan))
    return out


#: Thruster lags [s] tried for the starting point (the fit refines the best one).
LAG_GRID = tuple(0.025 * k for k in range(17))


def _initial_guess(experiments: Sequence[Experiment], stage: Stage, profile: Profile,
                   lags: Sequence[float]) -> tuple[dict[str, float], dict[str, float]]:
    """Equation-error start (module docstring, step 1) for the stage's DOFs and the lag
    (the one of ``lags`` with the smallest equation error), and the share scale of each
    hydrodynamic parameter: RMS of its regressor (ν̇_i, ν_i or ν_i²) over the RMS of
    τ_i − g_i, so that |δ|·scale is the share of the force or moment of DOF i that a change
    δ of the parameter makes at the experiments' typical motion."""
    m = profile.mass_kg
    q_rest = restoring_vector(profile)
    regressors: dict[int, FloatArray] = {}
    forces: dict[float, dict[int, FloatArray]] = {lag: {} for lag in lags}
    smooth = []
    for e in experiments:
        window = max(5, 2 * round(0.15 / e.h_s) + 1)
        smooth.append((savgol_filter(e.nu, window, 2, axis=0),
                       savgol_filter(e.nu, window, 2, deriv=1, delta=e.h_s, axis=0),
                       restoring_matrix(e.eta[:, 3], e.eta[:, 4]) @ q_rest))
    for i in stage.dofs:
        regressors[i] = np.concatenate([np.column_stack([dnu[:, i], nu[:, i],
                                                         np.abs(nu[:, i]) * nu[:, i]])
                                        for nu, dnu, _ in smooth])
        for lag in lags:
            forces[lag][i] = np.concatenate([lagged_thrust(e.tau, lag, e.h_s)[0][:, i] - g[:, i]
                                             for e, (_, _, g) in zip(experiments, smooth,
                                                                     strict=True)])

    def solve(lag: float) -> tuple[float, dict[int, FloatArray]]:
        total, sols = 0.0, {}
        for i in stage.dofs:
            A, b = regressors[i], forces[lag][i]
            scale = np.maximum(np.abs(A).max(axis=0), 1e-12)
            sol, res = nnls(A / scale, b)
            sols[i] = sol / scale
            total += (res / max(float(np.linalg.norm(b)), 1e-12)) ** 2
        return total, sols

    best = min(lags, key=lambda lag: solve(lag)[0])
    sols = solve(best)[1]
    guess: dict[str, float] = {LAG: best}
    share: dict[str, float] = {}
    for i in stage.dofs:
        sol = sols[i]
        total_mass = max(float(sol[0]), 1e-6)
        guess[HYDRO_NAMES[i]] = max(total_mass - m, 0.0) if i < 3 else total_mass
        guess[HYDRO_NAMES[6 + i]] = -float(sol[1])
        guess[HYDRO_NAMES[12 + i]] = -float(sol[2])
        b = forces[best][i]
        force = max(float(np.sqrt(np.mean(b * b))), 1e-12)
        for k, rms in enumerate(np.sqrt(np.mean(regressors[i] ** 2, axis=0))):
            share[HYDRO_NAMES[6 * k + i]] = float(rms) / force
    return guess, share


def _bounds(name: str, h: float) -> tuple[float, float]:
    if name == LAG:
        return 0.0, 1.0
    if name == LEAD:
        return 0.0, h
    if name.startswith("b_"):
        return -np.inf, np.inf
    k = HYDRO_NAMES.index(name)
    return (0.0, np.inf) if k < 6 else (-np.inf, 0.0)


def _step(name: str, value: float, problem: Problem) -> float:
    """Signed finite-difference step: relative, towards the interior of the bounds."""
    if name in (LAG, LEAD):
        return 1e-5
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
              options: FitOptions | None = None) -> StageFit:
    """Identify the parameters of ``stage`` (module docstring).

    Parameters
    ----------
    experiments : open-loop records of this stage (same sample interval).
    profile : mass, buoyancy and its centre (fixed), and the prior of every hydrodynamic
        parameter the stage does not estimate.
    stage : uvr, uwq or uvwpqr.

    Raises
    ------
    EstimationError
        For an unknown stage, unknown fixed parameters, or a fit that does not converge to
        finite values.
    """
    opts = options or FitOptions()
    if stage not in STAGES:
        raise EstimationError(f"unknown stage '{stage}' (stages: {', '.join(STAGES)})")
    st = STAGES[stage]
    h = experiments[0].h_s if experiments else 0.02
    problem = Problem(experiments, st, profile.mass_kg, restoring_vector(profile),
                      max(2, round(opts.segment_s / h)), _weights(experiments, st,
                                                                  opts.weights))
    unknown = set(opts.fixed) - set(problem.names)
    if unknown:
        raise EstimationError(f"cannot fix unknown parameters {sorted(unknown)} "
                              f"(known: {', '.join(problem.names)})")
    prior = prior_values(profile) | {LAG: opts.lag_s, LEAD: 0.5 * problem.h}
    theta = np.array([prior.get(n, 0.0) for n in problem.names])
    fit_lag = opts.fit_lag and LAG not in opts.fixed
    lags = LAG_GRID if fit_lag else (opts.fixed.get(LAG, opts.lag_s),)
    guess, share = _initial_guess(experiments, st, profile, lags)
    for name, v in guess.items():
        theta[problem.index[name]] = v
    free = [problem.index[n] for n in st.free_names if n not in opts.fixed]
    free += [i for i, n in enumerate(problem.names) if n.startswith("b_")
             and n not in opts.fixed]
    free += [problem.index[n] for n in (LAG, LEAD) if opts.fit_lag and n not in opts.fixed]
    for name, v in opts.fixed.items():
        theta[problem.index[name]] = v
    warnings: list[str] = []
    notes: dict[str, str] = {}
    nfev = 0
    while True:
        theta, J, nf = _solve(problem, theta, free, opts.max_nfev)
        nfev += nf
        cov, rms = _covariance(problem, theta, J)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        # not determined: uncertain relative to the value, and not negligible either (its
        # uncertainty moves more than MIN_SHARE of the DOF's force at the typical motion)
        rel = [(float(std[j] / abs(theta[i])) if theta[i] != 0 and np.isfinite(std[j])
                else np.inf, j) for j, i in enumerate(free) if problem.names[i] in HYDRO_NAMES
               and not std[j] * share[problem.names[i]] < MIN_SHARE]
        worst = max(rel, default=(0.0, -1))
        if worst[1] < 0 or worst[0] <= opts.max_rel_std:
            break
        i = free[worst[1]]
        name = problem.names[i]
        warnings.append(f"{stage}: {name} is not determined by the data (estimate "
                        f"{theta[i]:.4g} ± {std[worst[1]]:.2g}); fixed at the profile's "
                        f"{prior[name]:.4g}")
        notes[name] = "not determined: fixed at the profile's value"
        theta[i] = prior[name]
        free.remove(i)
    if not np.all(np.isfinite(theta)):
        raise EstimationError(f"{stage}: the fit diverged")
    d = np.sqrt(np.diag(cov))
    corr = cov / np.outer(np.where(d > 0, d, 1.0), np.where(d > 0, d, 1.0))
    std_of = {problem.names[i]: float(std[j]) for j, i in enumerate(free)}
    params = tuple(ParameterEstimate(n, float(theta[k]), std_of.get(n, float("nan")),
                                     prior.get(n, 0.0), n in std_of, notes.get(n, ""))
                   for k, n in enumerate(problem.names))
    return StageFit(stage, params, corr, tuple(problem.names[i] for i in free), rms,
                    sum(len(e.t_s) for e in experiments), nfev, tuple(warnings), share)


def _solve(problem: Problem, theta: FloatArray, free: list[int], max_nfev: int
           ) -> tuple[FloatArray, FloatArray, int]:
    """Trust-region reflective least squares over the ``free`` parameters."""
    names = [problem.names[i] for i in free]
    lower, upper = np.array([_bounds(n, problem.h) for n in names]).T
    x0 = np.clip(theta[free], lower, upper)

    def full(x: FloatArray) -> FloatArray:
        t = theta.copy()
        t[free] = x
        return t

    def fun(x: FloatArray) -> FloatArray:
        return problem.residuals(full(x))

    def jac(x: FloatArray) -> FloatArray:
        t = full(x)
        steps = np.array([_step(n, t[i], problem) for n, i in zip(names, free, strict=True)])
        return problem.jacobian(t, free, steps)

    res = least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf",
                        x_scale="jac", max_nfev=max_nfev, xtol=1e-10, ftol=1e-10)
    out = full(res.x)
    return out, np.asarray(res.jac), int(res.nfev + res.njev)


def _covariance(problem: Problem, theta: FloatArray, J: FloatArray
                ) -> tuple[FloatArray, float]:
    r = problem.residuals(theta)
    n, p = J.shape
    s2 = float(r @ r) / max(n - p, 1)
    cov: FloatArray = s2 * np.linalg.pinv(J.T @ J)
    return cov, float(np.sqrt(np.mean(r * r)))


def validate(values: Mapping[str, float], experiments: Sequence[Experiment],
             profile: Profile, stage: str) -> list[Validation]:
    """Free-run simulation of each experiment with the parameter ``values`` (bias
    parameters are not carried over: another session has another gyro bias) from its
    measured initial state; NRMSE per output of ``stage``."""
    st = STAGES[stage]
    prior = prior_values(profile) | {LAG: 0.0, LEAD: 0.5 * experiments[0].h_s}
    out = []
    for e in experiments:
        problem = Problem([e], st, profile.mass_kg, restoring_vector(profile), None,
                          np.ones(len(st.outputs)))
        theta = np.array([values.get(n, prior.get(n, 0.0)) if not n.startswith("b_") else 0.0
                          for n in problem.names])
        y_hat = problem.simulate(theta)[:, 0, 0]
        y = problem.y[:, 0]
        out.append(Validation(e.label, tuple(STATE_NAMES[s] for s in st.outputs),
                              tuple(float(v) for v in nrmse(y, y_hat)), e.t_s[1:], y, y_hat))
    return out
