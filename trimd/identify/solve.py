"""The output-error optimisation: a bounded Levenberg–Marquardt least squares on the
normal equations, and the parameter covariance of a least-squares fit.

A stage's residual vector is long (10⁵–10⁶ weighted output errors) and its parameter
vector short (≤ 30), so each iteration forms JᵀJ and Jᵀr once (one matrix product) and
works on the p × p system: no factorisation of the tall Jacobian (an SVD of it cost more
than the simulations). Bounds are kept by projection: a parameter on its bound whose step
points outwards is held for that step.

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from trimd.core.types import FloatArray

__all__ = ["Solution", "jacobian_covariance", "levenberg_marquardt"]



@dataclass(frozen=True, eq=False)
class Solution:
    """Result of :func:`levenberg_marquardt`.

    Attributes
    ----------
    x : parameters at the optimum.
    r : residuals at ``x``.
    J : Jacobian at ``x`` (the last one computed: at ``x`` unless the iteration limit
        stopped the search after an accepted step).
    nfev : residual evaluations plus Jacobian evaluations.
    """

    x: FloatArray
    r: FloatArray
    J: FloatArray
    nfev: int


def levenberg_marquardt(residuals_and_jacobian: Callable[[FloatArray],
                                                         tuple[FloatArray, FloatArray]],
                        residuals: Callable[[FloatArray], FloatArray], x0: FloatArray,
                        lower: FloatArray, upper: FloatArray, *, max_iter: int = 30,
                        ftol: float = 1e-8, xtol: float = 1e-8) -> Solution:
    """Minimise ‖r(x)‖² subject to lower ≤ x ≤ upper.

    Parameters
    ----------
    residuals_and_jacobian : r(x) and its Jacobian ∂r/∂x (n × p) at x.
    residuals : r(x) alone (trial steps).
    x0 : start (clipped into the bounds).
    lower, upper : bounds (±inf for none).
    max_iter : Jacobian evaluations at most.
    ftol : stop when an accepted step lowers the cost by less than this share.
    xtol : stop when the scaled step is below this share of the scaled parameters.

    Examples
    --------
    A straight line through three points, slope bounded below by 2:

    >>> t = np.array([0.0, 1.0, 2.0]); y = np.array([0.0, 1.0, 2.0])
    >>> def rj(x): return (x[0] + x[1] * t - y), np.column_stack([np.ones(3), t])
    >>> s = levenberg_marquardt(rj, lambda x: rj(x)[0], np.array([1.0, 3.0]),
    ...                         np.array([-np.inf, 2.0]), np.array([np.inf, np.inf]))
    >>> [round(float(v), 6) for v in s.x]
    [-1.0, 2.0]
    """
    x = np.clip(np.asarray(x0, float), lower, upper)
    r, J = residuals_and_jacobian(x)
    nfev = 1
    cost = float(r @ r)
    mu = 1e-3
    for _ in range(max_iter):
        A, g = J.T @ J, J.T @ r
        d = np.sqrt(np.diag(A))
        d[d == 0] = 1.0
        As, gs = A / np.outer(d, d), g / d
        accepted = False
        while mu < 1e12:
            step = _bounded_step(As, gs, d, mu, x, lower, upper)
            x_new = np.clip(x + step, lower, upper)
            r_new = residuals(x_new)
            nfev += 1
            cost_new = float(r_new @ r_new) if np.all(np.isfinite(r_new)) else np.inf
            if cost_new < cost:
                accepted = True
                break
            mu *= 4.0
        if not accepted:
            break
        small_step = np.linalg.norm(d * (x_new - x)) <= xtol * (np.linalg.norm(d * x) + xtol)
        small_gain = cost - cost_new <= ftol * cost
        x, cost, mu = x_new, cost_new, max(mu / 3.0, 1e-9)
        r, J = residuals_and_jacobian(x)
        nfev += 1
        if small_step or small_gain:
            break
    return Solution(x, r, J, nfev)


def _bounded_step(As: FloatArray, gs: FloatArray, d: FloatArray, mu: float, x: FloatArray,
                  lower: FloatArray, upper: FloatArray) -> FloatArray:
    """The damped Gauss–Newton step (As + μ·I)·s = −gs in the scaled parameters, with the
    parameters on a bound that the step would push outwards held."""
    p = len(x)
    free = np.ones(p, bool)
    for _ in range(p + 1):
        idx = np.flatnonzero(free)
        s = np.zeros(p)
        M = As[np.ix_(idx, idx)] + mu * np.eye(len(idx))
        s[idx] = np.linalg.solve(M, -gs[idx])
        step = s / d
        out = free & (((x <= lower) & (step < 0)) | ((x >= upper) & (step > 0)))
        if not out.any():
            return step
        free &= ~out
    return np.zeros(p)


def jacobian_covariance(J: FloatArray, r: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Standard deviations (units of the parameters) and correlation matrix of the
    parameters of a least-squares fit with Jacobian ``J`` (n × p) and residuals ``r``
    (n,): cov = s²·(JᵀJ)⁻¹, s² = ‖r‖²/(n − p).

    The inverse is taken of the column-scaled Jacobian J·D⁻¹ (D the column norms) through
    its singular values. The columns span many orders of magnitude (a gyro bias in rad/s
    beside a quadratic damping in N·m·s²/rad²): a pseudo-inverse of the unscaled JᵀJ cuts
    the weakly determined directions off as rank deficiency and so reports them as exact.
    A parameter that does not change the residuals at all gets an infinite standard
    deviation (and NaN correlations).

    Examples
    --------
    Two parameters 10¹⁰ apart in effect (s²·pinv(JᵀJ) gives 5e-15 for the second):

    >>> J = np.array([[1e4, 0.0], [0.0, 1e-6], [1e4, 1e-6]])
    >>> std, _ = jacobian_covariance(J, np.array([1.0, -1.0, 0.5]))
    >>> [f"{v:.3g}" for v in std]
    ['0.000122', '1.22e+06']
    """
    n, p = J.shape
    s2 = float(r @ r) / max(n - p, 1)
    norms = np.linalg.norm(J, axis=0)
    live = np.flatnonzero(norms > 0)
    std = np.full(p, np.inf)
    corr = np.full((p, p), np.nan)
    np.fill_diagonal(corr, 1.0)
    if live.size:
        # R of the scaled J has its singular values: a QR of the tall matrix, an SVD of R
        R = np.linalg.qr(J[:, live] / norms[live], mode="r")
        _, sv, vt = np.linalg.svd(R, full_matrices=False)
        sv = np.maximum(sv, sv[0] * np.finfo(float).eps)
        cov = (vt.T / sv ** 2) @ vt                      # of the scaled parameters
        d = np.sqrt(np.diag(cov))
        std[live] = np.sqrt(s2) * d / norms[live]
        corr[np.ix_(live, live)] = cov / np.outer(d, d)
    return std, corr
