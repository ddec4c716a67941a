"""The equation-error first pass of a stage fit: a start that owes nothing to the prior.

Per excited DOF i, the rigid-body equation of motion without the coupling terms,

    M_i·ν̇_i − D_i·ν_i − D_i|i|·|ν_i|·ν_i = τ_i − g_i(η),

is linear in the mass entry and the two damping coefficients; ν_i and ν̇_i come from a
Savitzky–Golay filter (quadratic, 0.3 s window) of the measured velocity or rate, τ_i
through the thruster lag, g(η) from the fixed restoring terms. A non-negative least
squares (masses ≥ 0, damping derivatives ≤ 0) gives the start of the output-error fit,
for each thruster lag of :data:`LAG_GRID`, and the lag with the smallest equation error
starts the lag.

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trimd.core.model import restoring_matrix
from trimd.core.types import FloatArray
from trimd.identify.data import Experiment
from trimd.identify.model import HYDRO_NAMES, LAG, Stage, Statics, lagged_thrust

__all__ = ["LAG_GRID", "equation_error_start"]


#: Thruster lags [s] tried for the starting point (the fit refines the best one).
LAG_GRID = tuple(0.025 * k for k in range(17))


def equation_error_start(experiments: Sequence[Experiment], stage: Stage, statics: Statics,
                   lags: Sequence[float], step_s: float
                   ) -> tuple[dict[str, float], dict[str, float]]:
    """Equation-error start (module docstring) for the stage's DOFs and the lag
    (the one of ``lags`` with the smallest equation error), and the share scale of each
    hydrodynamic parameter: RMS of its regressor (ν̇_i, ν_i or ν_i²) over the RMS of
    τ_i − g_i, so that |δ|·scale is the share of the force or moment of DOF i that a change
    δ of the parameter makes at the experiments' typical motion.

    The mass entry is at least the one whose time constant at the fastest recorded speed
    is one integration step ``step_s`` (a stiffer start makes the RK4 simulation diverge)."""
    from scipy.optimize import nnls  # 1.5 s to import both: not for every identify import
    from scipy.signal import savgol_filter

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
            # the same non-negative least squares on the 3 × 3 triangle of a QR of the
            # tall regressor: ‖A·x − b‖² = ‖R·x − Qᵀb‖² + ‖b‖² − ‖Qᵀb‖²
            Q, R = np.linalg.qr(A / scale)
            qb = Q.T @ b
            sol, res = nnls(R, qb)
            sols[i] = sol / scale
            bb = float(b @ b)
            total += (res * res + max(bb - float(qb @ qb), 0.0)) / max(bb, 1e-24)
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
