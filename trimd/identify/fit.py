"""Grey-box identification of the 6-DOF model, stage by stage (docs/method.md §5).

For one stage (:data:`trimd.identify.model.STAGES`) and one or more experiments:

0. an excitation check (:func:`excitation_of`): per DOF of the stage, the spread of τ_i in
   the data against what the thrusters can give on that axis; a DOF below
   :data:`MIN_EXCITATION` is not fitted (its velocity and angle are taken from the
   measurements, its parameters keep the profile's values and the fit says so);
1. a starting point that owes nothing to the profile's hydrodynamic values: per excited
   DOF, a non-negative least-squares equation-error fit of M_i·ν̇_i − D_i·ν_i −
   D_i|i|·|ν_i|·ν_i = τ_i − g_i(η) on smoothed derivatives of the measurements;
2. an output-error fit with a bounded Levenberg–Marquardt least squares
   (:func:`trimd.identify.solve.levenberg_marquardt`; physical bounds: added masses ≥ 0,
   inertia sums > 0, damping derivatives ≤ 0, thruster lag in [0, 1] s) of the simulation
   error over short segments, each started from the measured state (a stable
   simulation-error objective that tolerates a poor start), all experiments in one cost,
   each output weighted by the inverse of its spread; the simulation steps over
   ``FitOptions.step_s`` (two samples at 50 Hz) and its Jacobian is one batched simulation
   of every perturbed parameter vector;
3. standard deviations and correlations from the Jacobian at the optimum
   (cov = s²·(JᵀJ)⁻¹, s² the residual variance, inverted on the column-scaled Jacobian:
   :func:`jacobian_covariance`; the simulation errors are correlated in time, so these
   are lower bounds), and a parameter whose relative standard deviation exceeds
   ``max_rel_std`` is reported, fixed at the profile's value and the fit repeated;
4. :func:`validate`: a free-run simulation of held-out experiments and the normalised RMSE
   fit 100·(1 − ‖y − ŷ‖/‖y − mean(y)‖) % per output.

The mass and the restoring terms are held fixed: the profile's nominal vehicle, or a
measured static estimate (:class:`trimd.identify.model.Statics`).

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls
from scipy.signal import savgol_filter

from trimd.core.errors import DataError, EstimationError
from trimd.core.model import restoring_matrix
from trimd.core.profile import Profile
from trimd.identify.data import Experiment
from trimd.identify.model import (
    HYDRO_NAMES,
    LAG,
    LEAD,
    STAGES,
    STATE_NAMES,
    Stage,
    Statics,
    lagged_thrust,
    prior_values,
    statics_of_profile,
)
from trimd.identify.problem import Problem
from trimd.identify.signals import axis_authority
from trimd.identify.solve import jacobian_covariance, levenberg_marquardt

__all__ = ["DOF_NAMES", "DofExcitation", "FitOptions", "ParameterEstimate", "StageFit",
           "Validation", "excitation_of", "fit_stage",
           "not_excited_message", "nrmse", "validate"]

FloatArray = NDArray[np.float64]
#: A parameter whose standard deviation moves less than this share of its DOF's force or
#: moment counts as determined (negligible) even when its relative uncertainty is large.
MIN_SHARE = 0.02
#: A DOF counts as excited when the spread of its generalised force τ_i in the data (the
#: standard deviation about each experiment's mean) is at least this share of what the
#: thrusters can give on that axis (:func:`trimd.identify.signals.axis_authority`). Measured on
#: the simulator (docs/identification.md): 3.4–34 % on the axes a stage excites, at most
#: 1.4 % on the others (the BlueROV2 Heavy's attitude hold).
MIN_EXCITATION = 0.02
#: Degrees of freedom and the symbols of their generalised forces, in order.
DOF_NAMES = ("surge", "sway", "heave", "roll", "pitch", "yaw")
_FORCE_NAMES = ("X", "Y", "Z", "K", "M", "N")


@dataclass(frozen=True)
class FitOptions:
    """Settings of :func:`fit_stage`.

    Attributes
    ----------
    segment_s : simulation horizon of each segment [s].
    step_s : longest integration step of the fit [s]: the simulation steps over whole
        samples, as many as fit in it (at least one), and is compared at those samples.
    weights : per output name (u, v, w, p, q, r, phi, theta) the weight of its error;
        outputs not named get 1/std of the measured output.
    lag_s : thruster lag [s] when it is not fitted.
    fit_lag : estimate the thruster lag (starting from the best of :data:`LAG_GRID`) and
        the lead of the thruster record (starting from half a sample interval).
    fixed : parameters held at the given value (named as in the report).
    max_rel_std : relative standard deviation above which a parameter counts as not
        determined by the data.
    max_iter : Jacobian evaluations (iterations) per least-squares run.
    min_excitation : share of the thrusters' authority the spread of τ_i must reach for
        DOF i to be fitted (:data:`MIN_EXCITATION`, :func:`excitation_of`).
    """

    segment_s: float = 4.0
    step_s: float = 0.04
    weights: Mapping[str, float] = field(default_factory=dict)
    lag_s: float = 0.05
    fit_lag: bool = True
    fixed: Mapping[str, float] = field(default_factory=dict)
    max_rel_std: float = 0.3
    max_iter: int = 30
    min_excitation: float = MIN_EXCITATION


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


@dataclass(frozen=True)
class DofExcitation:
    """How much the experiments excited one degree of freedom.

    Attributes
    ----------
    dof : 0..5 (surge, sway, heave, roll, pitch, yaw).
    spread : standard deviation of τ_i about each experiment's mean [N or N·m].
    authority : what the thrusters can give on that axis [N or N·m]
        (:func:`trimd.identify.signals.axis_authority`).
    threshold : the share of ``authority`` the spread must reach (:data:`MIN_EXCITATION`).
    """

    dof: int
    spread: float
    authority: float
    threshold: float

    @property
    def ratio(self) -> float:
        """Spread over authority (0.01 = 1 %)."""
        return self.spread / self.authority if self.authority > 0 else 0.0

    @property
    def excited(self) -> bool:
        return self.ratio >= self.threshold

    @property
    def name(self) -> str:
        return DOF_NAMES[self.dof]

    def describe(self) -> str:
        """E.g. "τ_Z spread 0.73 %" (of the authority)."""
        return f"τ_{_FORCE_NAMES[self.dof]} spread {100 * self.ratio:.2g} %"


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
    excitation : per DOF of the stage, how much the data excited it; the parameters of a
        DOF that was not excited are not fitted (profile's values, noted).
    statics : the mass and restoring terms the fit held fixed.
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
    excitation: tuple[DofExcitation, ...] = ()
    statics: Statics | None = None

    @property
    def not_excited(self) -> tuple[DofExcitation, ...]:
        """The DOFs of the stage the data did not excite (their parameters not fitted)."""
        return tuple(d for d in self.excitation if not d.excited)

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


def _initial_guess(experiments: Sequence[Experiment], stage: Stage, statics: Statics,
                   lags: Sequence[float], step_s: float
                   ) -> tuple[dict[str, float], dict[str, float]]:
    """Equation-error start (module docstring, step 1) for the stage's DOFs and the lag
    (the one of ``lags`` with the smallest equation error), and the share scale of each
    hydrodynamic parameter: RMS of its regressor (ν̇_i, ν_i or ν_i²) over the RMS of
    τ_i − g_i, so that |δ|·scale is the share of the force or moment of DOF i that a change
    δ of the parameter makes at the experiments' typical motion.

    The mass entry is at least the one whose time constant at the fastest recorded speed
    is one integration step ``step_s`` (a stiffer start makes the RK4 simulation diverge)."""
    m = statics.mass_kg
    q_rest = statics.q_rest
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
    h = step_s
    for i in stage.dofs:
        sol = sols[i]
        fastest = max(float(np.abs(e.nu[:, i]).max()) for e in experiments)
        total_mass = max(float(sol[0]), h * float(sol[1] + 2 * sol[2] * fastest), 1e-6)
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
        upper = _bounds(name, problem.h)[1]
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


def excitation_of(experiments: Sequence[Experiment], profile: Profile, stage: Stage,
                  threshold: float = MIN_EXCITATION) -> tuple[DofExcitation, ...]:
    """Per DOF of ``stage``, the spread of τ_i in ``experiments`` (standard deviation about
    each experiment's own mean, pooled: a constant trim force is no excitation) against
    the thrusters' authority on that axis (:func:`trimd.identify.signals.axis_authority`)."""
    authority = axis_authority(profile)
    tau = np.concatenate([e.tau - e.tau.mean(axis=0) for e in experiments])
    spread = np.sqrt(np.mean(tau * tau, axis=0))
    return tuple(DofExcitation(i, float(spread[i]), float(authority[i]), threshold)
                 for i in stage.dofs)


def _join(words: Sequence[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def not_excited_message(stage: str, missing: Sequence[DofExcitation]) -> str:
    """What is wrong and what to do when DOFs of ``stage`` were not excited."""
    verb = "was" if len(missing) == 1 else "were"
    return (f"{_join([d.name for d in missing])} {verb} not excited in these logs "
            f"({', '.join(d.describe() for d in missing)} of what the thrusters give, at "
            f"least {100 * missing[0].threshold:g} % needed): their parameters were not "
            f"identified and keep the profile's values. Record an experiment of this stage "
            f"(trimd excite --stage {stage}) and fit that")


def _reduced(stage: Stage, dofs: tuple[int, ...]) -> Stage:
    """``stage`` restricted to ``dofs``: the other velocities and angles are taken from the
    measurements (roll angle with roll, pitch angle with pitch)."""
    angles = tuple(a for a, dof in ((6, 3), (7, 4)) if dof in dofs and a in stage.states)
    return Stage(stage.name, dofs, tuple(s for s in stage.states if s in dofs) + angles,
                 stage.axes)


def fit_stage(experiments: Sequence[Experiment], profile: Profile, stage: str,
              options: FitOptions | None = None, *, statics: Statics | None = None
              ) -> StageFit:
    """Identify the parameters of ``stage`` (module docstring).

    Only the DOFs the data excited (:func:`excitation_of`) are fitted; the parameters of
    the others keep the profile's values, and :attr:`StageFit.warnings` says so.

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
    excitation = excitation_of(experiments, profile, STAGES[stage], opts.min_excitation)
    missing = tuple(d for d in excitation if not d.excited)
    if len(missing) == len(excitation):
        raise EstimationError(f"{stage}: nothing to identify: "
                              + not_excited_message(stage, missing))
    st = _reduced(STAGES[stage], tuple(d.dof for d in excitation if d.excited))
    problem, theta, free, prior, share = _setup(experiments, profile, st, opts, fixed_by)
    theta, std, corr, rms, free, warnings, notes, nfev = _fit(problem, theta, free, prior,
                                                                share, opts, stage)
    if missing:
        warnings.insert(0, f"{stage}: " + not_excited_message(stage, missing))
        for n in STAGES[stage].free_names:
            if n not in st.free_names:
                notes[n] = "not excited: profile's value"
    std_of = {problem.names[i]: float(std[j]) for j, i in enumerate(free)}
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
    guess, share = _initial_guess(experiments, st, statics, lags, problem.step)
    for name, v in guess.items():
        theta[problem.index[name]] = v
    free = [problem.index[n] for n in st.free_names if n not in opts.fixed]
    free += [i for i, n in enumerate(problem.names) if n.startswith("b_")
             and n not in opts.fixed]
    free += [problem.index[n] for n in (LAG, LEAD) if opts.fit_lag and n not in opts.fixed]
    for name, v in opts.fixed.items():
        theta[problem.index[name]] = v
    return problem, theta, free, prior, share


def _fit(problem: Problem, theta: FloatArray, free: list[int], prior: Mapping[str, float],
         share: Mapping[str, float], opts: FitOptions, stage: str
         ) -> tuple[FloatArray, FloatArray, FloatArray, float, list[int], list[str],
                    dict[str, str], int]:
    """Output-error fit, then fix the worst undetermined parameter at the profile's value
    and repeat until every free one is determined (module docstring, step 3). Returns
    θ, the standard deviations and correlations of the free parameters, the RMS residual,
    the free indices, warnings, notes per parameter and the simulations run."""
    warnings: list[str] = []
    notes: dict[str, str] = {}
    nfev = 0
    while True:
        theta, r, J, nf = _solve(problem, theta, free, opts.max_iter)
        nfev += nf
        std, corr = jacobian_covariance(J, r)
        rms = float(np.sqrt(np.mean(r * r)))
        j = _worst_undetermined(problem, theta, free, std, share, opts.max_rel_std)
        if j < 0:
            break
        i = free[j]
        name = problem.names[i]
        warnings.append(f"{stage}: {name} is not determined by the data (estimate "
                        f"{theta[i]:.4g} ± {std[j]:.2g}); fixed at the profile's "
                        f"{prior[name]:.4g}")
        notes[name] = "not determined: fixed at the profile's value"
        theta[i] = prior[name]
        free.remove(i)
    if not np.all(np.isfinite(theta)):
        raise EstimationError(f"{stage}: the fit diverged")
    return theta, std, corr, rms, free, warnings, notes, nfev


def _worst_undetermined(problem: Problem, theta: FloatArray, free: Sequence[int],
                        std: FloatArray, share: Mapping[str, float], max_rel_std: float
                        ) -> int:
    """Position in ``free`` of the hydrodynamic parameter with the largest relative
    standard deviation, if that exceeds ``max_rel_std``, among those that are not
    negligible (their uncertainty moves at least :data:`MIN_SHARE` of their DOF's force at
    the typical motion); −1 if there is none."""
    candidates = []
    for j, i in enumerate(free):
        name = problem.names[i]
        sd = float(std[j]) if np.isfinite(std[j]) else np.inf
        if name not in HYDRO_NAMES or sd * share[name] < MIN_SHARE:
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
    lower, upper = np.array([_bounds(n, problem.h) for n in names]).T

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


def validate(values: Mapping[str, float], experiments: Sequence[Experiment],
             profile: Profile, stage: str, *, statics: Statics | None = None
             ) -> list[Validation]:
    """Free-run simulation of each experiment with the parameter ``values`` (bias
    parameters are not carried over: another session has another gyro bias) from its
    measured initial state; NRMSE per output of ``stage``. ``statics``: the mass and
    restoring terms (default: the profile's nominal vehicle)."""
    st = STAGES[stage]
    fixed_by = statics or statics_of_profile(profile)
    prior = prior_values(profile) | {LAG: 0.0, LEAD: 0.5 * experiments[0].h_s}
    out = []
    for e in experiments:
        problem = Problem([e], st, fixed_by.mass_kg, fixed_by.q_rest, None,
                          np.ones(len(st.outputs)))
        theta = np.array([values.get(n, prior.get(n, 0.0)) if not n.startswith("b_") else 0.0
                          for n in problem.names])
        y_hat = problem.simulate(theta)[:, 0, 0]
        y = problem.y[:, 0]
        out.append(Validation(e.label, tuple(STATE_NAMES[s] for s in st.outputs),
                              tuple(float(v) for v in nrmse(y, y_hat)), e.t_s[1:], y, y_hat))
    return out
