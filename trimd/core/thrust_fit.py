"""The thrust map's errors fitted to calibration experiments (docs/method.md §7).

Each experiment predicts the change of τ between its two level holds on the rows they
measure (Z, K, M) as a function of the errors z [prior σ] of
:mod:`trimd.core.curve_error`: the holds' thruster outputs (their histograms,
:mod:`trimd.core.output_hist`) read through the profile's curves with the errors z. The
prediction is then nonlinear where it matters: a dead band that starts later takes up to
a whole edge thrust away from the samples between the edges, one that starts earlier
adds only slope × offset. An experiment whose holds kept no outputs (recorded before
they were) predicts linearly, the change by the profile's map plus H·z, H its thrust
map factors.

z is fitted by ``scipy.optimize.least_squares`` to every experiment's prediction against
its target, the change G₂·q₂ − G₁·q₁ that the known ballast change makes, whitened by the
experiment's covariance R, with a Gaussian prior on z (rows of its own). Its covariance is
the Laplace approximation (JᵀJ)⁻¹ at the fit, J the whitened Jacobian. An experiment is
checked against what is known before it (:func:`innovation`) with the prediction's secant
over ± each parameter's σ: near a band the tangent is flat where the secant is not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import solve_triangular

from trimd.core.curve_error import thrusters_with_errors
from trimd.core.hunting import EdgeObservation
from trimd.core.output_hist import OutputHistogram, mean_thrust
from trimd.core.profile import Profile, Thruster
from trimd.core.types import FloatArray

__all__ = ["ChangeModel", "Gaussian", "fit", "innovation", "predicted"]

#: Step of the fit's finite differences, and the least of the check's [prior σ]: small
#: against the errors' scale and against a band edge's travel over one 1 µs histogram bin
#: (σ_band ≈ 2.9 µs).
_STEP = 1e-3


@dataclass(frozen=True, eq=False)
class ChangeModel:
    """One experiment as the fit sees it.

    Attributes
    ----------
    label : the experiment's.
    rows : which rows of τ it measures.
    target : the change of τ on its rows that the known ballast makes [N, N·m].
    R : covariance of the prediction's error (noise, wander, the inventory, attitude).
    T_rows : the thrust configuration's rows, shape (rows, n).
    before, after : the holds' output histograms; None when a hold kept none.
    measured : the change of τ by the profile's map [N, N·m] (the linear prediction's).
    H : the thrust map factors of the change, shape (rows, 4·n) [per prior σ].
    hunting : the hunting spikes of the holds (before, after): their samples delivered
        whatever balanced, whatever the curves (:func:`~trimd.core.output_hist.
        mean_thrust`), and the errors z cannot be read from them.
    """

    label: str
    rows: NDArray[np.bool_]
    target: FloatArray
    R: FloatArray
    T_rows: FloatArray
    before: OutputHistogram | None
    after: OutputHistogram | None
    measured: FloatArray
    H: FloatArray
    hunting: tuple[tuple[EdgeObservation, ...], tuple[EdgeObservation, ...]] = ((), ())


@dataclass(frozen=True, eq=False)
class Gaussian:
    """A Gaussian of z: mean, shape (4·n,), and a lower factor L of its covariance."""

    mean: FloatArray
    sqrt_cov: FloatArray


def predicted(model: ChangeModel, thrusters: Sequence[Thruster], z: FloatArray) -> FloatArray:
    """The change of τ on ``model``'s rows [N, N·m] that ``thrusters`` (the profile's
    with the errors ``z``) make of its holds' outputs."""
    if model.before is None or model.after is None:
        change: FloatArray = model.measured + model.H @ z
        return change
    before, after = model.hunting
    f = (mean_thrust(model.after, thrusters, after)
         - mean_thrust(model.before, thrusters, before))
    out: FloatArray = model.T_rows @ f
    return out


def _jacobian(model: ChangeModel, profile: Profile, z: FloatArray, spread: FloatArray
              ) -> FloatArray:
    """∂ predicted / ∂z about ``z``, shape (rows, 4·n): per parameter the central
    difference over ± its ``spread`` [prior σ] (at least :data:`_STEP`), a secant over
    the values it may take, not the tangent at ``z``. Near a dead band the tangent is
    flat: an output inside the profile's band gives no thrust at z and none a thousandth
    of a σ away, though a band 1σ off gives it thrust (the weight-then-float series of
    ``tests/app/test_calibration_history.py`` on seed 0: a thruster resting 1–3 µs inside
    its table's band, its edge 3.8 µs off, put the check 3.7σ out along a moment the
    tangent said nothing could move)."""
    if model.before is None or model.after is None:
        return model.H
    J = np.empty((len(model.target), len(z)))
    for k, h in enumerate(np.maximum(spread, _STEP)):
        up, down = z.copy(), z.copy()
        up[k] += h
        down[k] -= h
        J[:, k] = (predicted(model, thrusters_with_errors(profile, up), up)
                   - predicted(model, thrusters_with_errors(profile, down), down)) / (2 * h)
    return J


def innovation(model: ChangeModel, profile: Profile, mean: FloatArray, cov: FloatArray
               ) -> tuple[FloatArray, FloatArray]:
    """What ``model`` shows beyond what the errors of mean ``mean`` and covariance ``cov``
    predict, v = target − predicted(mean), and its covariance J·P·Jᵀ + R (J the secant of
    each parameter over ± its σ about ``mean``, :func:`_jacobian`)."""
    v = model.target - predicted(model, thrusters_with_errors(profile, mean), mean)
    J = _jacobian(model, profile, mean, np.sqrt(np.diag(cov)))
    return v, J @ cov @ J.T + model.R


def fit(models: Sequence[ChangeModel], profile: Profile, prior: Gaussian,
        start: FloatArray) -> tuple[FloatArray, FloatArray]:
    """z fitted to ``models`` under ``prior`` from ``start``: its mean and its (Laplace)
    covariance."""
    from scipy.optimize import least_squares  # only when a calibration is fitted

    whiten = [np.linalg.inv(np.linalg.cholesky(m.R)) for m in models]
    prior_rows: NDArray[np.float64] = np.asarray(prior.sqrt_cov, float)

    def residuals(z: FloatArray) -> FloatArray:
        thrusters = thrusters_with_errors(profile, z)
        return np.concatenate([
            solve_triangular(prior_rows, z - prior.mean, lower=True),
            *(W @ (predicted(m, thrusters, z) - m.target)
              for m, W in zip(models, whiten, strict=True))])

    solution = least_squares(residuals, np.asarray(start, float), diff_step=_STEP)
    J = np.asarray(solution.jac, float)
    cov: FloatArray = np.linalg.inv(J.T @ J)
    mean: FloatArray = solution.x
    return mean, cov
