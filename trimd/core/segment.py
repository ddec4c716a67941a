"""What one steady segment of ordinary operation determines: a one-hold fit of g(η) = τ.

At one attitude (φ, θ) the restoring moments are (W·r_g − B·r_b) × k_b, with k_b the
world vertical in the body frame: the component of the net moment vector along k_b does
not show. So one segment determines at most three of the four net quantities
q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] (docs/method.md §3):

* level (φ, θ ≈ 0): k_b is the body z axis, and the Z, K, M rows give W − B,
  W·y_g − B·y_b and W·x_g − B·x_b directly; W·z_g − B·z_b (the height of the centre of
  gravity) is not observable;
* tilted: the unobservable direction mixes all three moments, so no single net moment is
  determined; W − B is, where the force rows count (a vehicle that keeps station, or a
  level segment). All four need two attitudes (:func:`trimd.core.estimate.estimate_static`
  over a level and a tilted segment).

The fit is :func:`~trimd.core.estimate.estimate_static`'s for one hold, restricted to the
directions the segment observes: q = q_prior + V_o·x, V_o the right singular vectors of
the rows used with a relative singular value of at least 0.02; the unobservable part
stays at ``q_prior`` and is flagged (:attr:`SegmentEstimate.observable`). The ± is the
same: the long-run covariance of the per-sample residual (noise and wander), the thrust
curves' gain errors, the attitude reference's slow error (the profile's
``attitude_error_deg``) and, at a tilt without station keeping, the drift's Munk moment.
The gain errors are kept apart (:attr:`SegmentEstimate.gain_sensitivity`): they are the
same at every segment of one vehicle, so a change test compares segments through the
*difference* of their exposures, not the sum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trimd.core.drift import DRIFT_MODEL_ERROR
from trimd.core.estimate import (
    MIN_RELATIVE_SINGULAR,
    MOMENT_ROWS,
    HoldSamples,
    check_samples,
    is_level,
    measurable_dofs,
    spikes_of,
)
from trimd.core.hunting import hunting_factors
from trimd.core.longrun import mean_covariance
from trimd.core.model import informative_rows, restoring_matrix
from trimd.core.profile import Profile
from trimd.core.systematics import (
    attitude_error_factors,
    drift_moments,
    thrust_map_bias,
    thrust_map_factors,
)
from trimd.core.types import FloatArray

__all__ = ["Q_NAMES", "SegmentEstimate", "estimate_segment", "nominal_q"]

#: The net quantities q, for people, in order.
Q_NAMES = ("W − B", "W·x_g − B·x_b", "W·y_g − B·y_b", "W·z_g − B·z_b")
#: A component of q is observable when the unobservable directions move it by less than
#: this share of their unit length.
_OBSERVABLE_LEAK = 0.05


@dataclass(frozen=True, eq=False)
class SegmentEstimate:
    """The net quantities of one segment (SI units, body FRD, 1σ).

    Attributes
    ----------
    label : name for people ("segment 3").
    t_start_s, t_end_s : first and last steady sample [s, the samples' own clock].
    roll_deg, pitch_deg : mean attitude [deg].
    samples : steady samples used.
    q : [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] [N, N·m]; components not
        ``observable`` hold the prior.
    q_cov : covariance of ``q`` with every source (noise, thrust curves, drift model).
    q_cov_noise : the noise-and-wander part alone (independent between segments).
    gain_sensitivity : how ``q`` moves with each systematic error of the thrust map, shape
        (4, 4·n), per 1σ (:func:`trimd.core.systematics.thrust_map_factors`: gains forward,
        reverse, dead-band edges positive, negative).
    observable : which of the four components this segment determines.
    resolved : the segment was long enough for its own correlation time.
    """

    label: str
    t_start_s: float
    t_end_s: float
    roll_deg: float
    pitch_deg: float
    samples: int
    q: FloatArray
    q_cov: FloatArray
    q_cov_noise: FloatArray
    gain_sensitivity: FloatArray
    observable: tuple[bool, bool, bool, bool]
    resolved: bool

    @property
    def q_std(self) -> FloatArray:
        """1σ of each component of ``q`` (NaN where not observable)."""
        std: FloatArray = np.where(self.observable, np.sqrt(np.diag(self.q_cov)), np.nan)
        return std


def nominal_q(profile: Profile) -> FloatArray:
    """q of the profile's nominal vehicle (centre of gravity at the origin CG0)."""
    q: FloatArray = np.r_[profile.weight_N - profile.buoyancy_N,
                          -profile.buoyancy_N * np.asarray(profile.r_b_m, float)]
    return q


def estimate_segment(hold: HoldSamples, profile: Profile,
                     q_prior: FloatArray | None = None) -> SegmentEstimate:
    """Fit q to one steady segment (module docstring). ``q_prior`` [N, N·m] fills the
    directions the segment does not observe (default :func:`nominal_q`).

    Raises
    ------
    EstimationError : fewer than 2 samples or non-finite data.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("bluerov2-heavy")
    >>> q = np.array([1.5, -0.2, 0.1, 0.4])
    >>> tau = restoring_matrix(0.0, 0.0) @ q
    >>> seg = estimate_segment(HoldSamples(np.arange(3.0), np.zeros(3), np.zeros(3),
    ...                                    np.tile(tau, (3, 1))), p)
    >>> [round(float(v), 6) for v in seg.q[:3]], seg.observable
    ([1.5, -0.2, 0.1], (True, True, True, False))
    """
    h = hold
    check_samples(h, "segment")
    prior = nominal_q(profile) if q_prior is None else np.asarray(q_prior, float)
    rows = np.array(measurable_dofs(profile), bool)
    phi, theta = float(np.mean(h.phi)), float(np.mean(h.theta))
    # as in estimate_static: rows without information at this attitude are left out
    used = (rows & (MOMENT_ROWS | (is_level(h) or profile.holds_station))
            & informative_rows(phi, theta))
    A = restoring_matrix(phi, theta)[used]
    _, s, vt = np.linalg.svd(A, full_matrices=False)
    r = int(np.sum(s >= MIN_RELATIVE_SINGULAR * s[0]))
    V_o = vt[:r].T
    V_u = np.linalg.svd(V_o.T)[2][r:].T if r < 4 else np.zeros((4, 0))
    o0, o1, o2, o3 = (bool(np.linalg.norm(V_u[i]) < _OBSERVABLE_LEAK) for i in range(4))
    observable = (o0, o1, o2, o3)
    B_o = A @ V_o
    tau = h.tau[:, used].mean(axis=0)
    factors = thrust_map_factors([h], [used], profile)[0]
    hunting = hunting_factors(spikes_of(h, profile), used, profile)
    if profile.thrust_map is not None:  # the calibration's mean correction of the map
        tau = tau + thrust_map_bias([h], [used], profile)[0]
    q = prior.copy()
    weights = np.ones(int(used.sum()))
    for _ in range(3):
        drift = drift_moments([(phi, theta)], [used], profile, float(q[0]))[0]
        L = np.linalg.pinv(B_o * weights[:, None]) * weights
        q = prior + V_o @ (L @ (tau - drift - A @ prior))
        e = h.tau[:, used] - np.einsum("nij,j->ni",
                                       restoring_matrix(h.phi, h.theta)[:, used], q)
        mc = mean_covariance(e)
        tilt = attitude_error_factors([(phi, theta)], [used], profile, q)[0]
        var = (np.diag(mc.interval_cov) + (factors**2).sum(axis=1) + (hunting**2).sum(axis=1)
               + (DRIFT_MODEL_ERROR * drift)**2 + (tilt**2).sum(axis=1))
        weights = 1 / np.sqrt(np.maximum(var, 1e-12 * max(float(var.max()), 1e-300)))
    J = V_o @ L  # q = prior + J·(τ̄ − drift − A·prior)
    noise = J @ (mc.interval_cov + hunting @ hunting.T) @ J.T   # hunting: this segment's
    gain = J @ factors
    d = J @ (DRIFT_MODEL_ERROR * drift)
    reference = J @ tilt
    cov = noise + gain @ gain.T + np.outer(d, d) + reference @ reference.T
    return SegmentEstimate(h.label, float(h.t_s[0]), float(h.t_s[-1]), float(np.degrees(phi)),
                           float(np.degrees(theta)), len(h.phi), q, cov, noise, gain,
                           observable, bool(mc.resolved))
