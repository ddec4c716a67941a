"""What is known of a vehicle's thrust map: a Gaussian of its errors z (units of the
prior 1σ, :mod:`trimd.core.curve_error`), the profile's own N(0, I) or what calibration
experiments (:mod:`trimd.core.calibration`) and the holds' own outputs
(:mod:`trimd.core.hunting`) taught (docs/method.md §3, §7)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trimd.core.errors import EstimationError
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

__all__ = ["ThrustMapPosterior", "posterior", "prior"]


@dataclass(frozen=True, eq=False)
class ThrustMapPosterior:
    """The Gaussian posterior of the thrust map's errors z (units of the prior 1σ, the
    order of :func:`~trimd.core.systematics.thrust_map_factors`' columns: gains forward,
    gains reverse, band edges negative, positive), shape (4·n,).

    Attributes
    ----------
    mean : μ, shape (4·n,).
    cov : P, shape (4·n, 4·n).
    sqrt_cov : L, lower triangular with L·Lᵀ = P (its columns from 2·n on are band
        errors alone, as the prior's).
    experiments : how many experiments it rests on.
    """

    mean: FloatArray
    cov: FloatArray
    sqrt_cov: FloatArray
    experiments: int


def posterior(mean: FloatArray, cov: FloatArray, experiments: int) -> ThrustMapPosterior:
    """The posterior of mean μ and covariance P (symmetrised; L by Cholesky, with the
    least diagonal jitter that makes P positive definite; EstimationError when none up to
    P's own scale does: P is not a covariance)."""
    cov = (cov + cov.T) / 2
    scale = float(np.max(np.abs(np.diag(cov)), initial=1.0))
    jitter = 0.0
    while jitter <= scale:
        try:
            L = np.linalg.cholesky(cov + jitter * np.eye(len(cov))).astype(np.float64)
            return ThrustMapPosterior(mean, cov, L, experiments)
        except np.linalg.LinAlgError:
            jitter = max(2 * jitter, 1e-12)
    raise EstimationError("the thrust map's posterior covariance is not a covariance "
                          "(not positive definite, or not finite)")


def prior(profile: Profile) -> ThrustMapPosterior:
    """The profile's own thrust map: z ~ N(0, I), no experiment."""
    k = 4 * len(profile.thrusters)
    return ThrustMapPosterior(np.zeros(k), np.eye(k), np.eye(k), 0)
