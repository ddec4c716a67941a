"""When has a hold collected enough? The stop rule, on the quantities the operator acts on.

The operator acts on a ballast proposal. It leaves the vehicle level to within the error
of the estimated net moments divided by the vehicle's metacentric stiffness, and its net
buoyancy off by the error of W − B. So collecting stops when, at 95 %,

- the passive roll and pitch the proposal would leave are within the profile's
  ``level_tol_deg``: z·σ(W·y_g − B·y_b)/k ≤ tol and z·σ(W·x_g − B·x_b)/k ≤ tol, with
  k = W·z_g − B·z_b [N·m/rad] the stiffness (restoring moment per radian of tilt: the
  estimate's once the tilted hold is in, the profile's before);
- W − B is known to within half the profile's net-buoyancy window:
  z·σ(W − B) ≤ (high − low)/2 % of the weight;
- the stiffness itself is known to within :data:`STIFFNESS_TOLERANCE` of its value;
- every hold is worth at least ``MIN_EFFECTIVE`` independent samples (its ± is resolved).

A vehicle with a small metacentric height (a BlueROV2: k ≈ 1–3 N·m/rad) therefore
collects longer than a stiff one, as it must. The rule is checked only at a fixed
schedule of looks (collection times growing by :data:`LOOK_GROWTH` from ``min_steady_s``
to ``collect_max_s``), and z is the Bonferroni quantile for that many looks, so that the
chance that any look stops on a too-optimistic σ stays within 5 %. Units: N, N·m, rad, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri  # scipy.stats' norm.ppf, without its 1 s import

from trimd.core.estimate import HoldSamples, StaticEstimate
from trimd.core.longrun import mean_covariance
from trimd.core.model import informative_rows, restoring_matrix
from trimd.core.profile import Profile
from trimd.core.systematics import thrust_map_std
from trimd.core.types import FloatArray

__all__ = ["LOOK_GROWTH", "STIFFNESS_TOLERANCE", "StopRule"]

#: Each look comes this many times later (in collection time) than the one before.
LOOK_GROWTH = 1.5
#: The stiffness must be known to this share of its value.
STIFFNESS_TOLERANCE = 0.1
#: Collecting also stops when the noise part of a σ is at most this share of the part that
#: collecting does not reduce (thrust curves, drift model): the ± is then within 12 % of
#: what any length of collecting could give.
NOISE_SHARE = 0.5
#: The chance that the decision is wrong, over all looks together.
ALPHA = 0.05
@dataclass(frozen=True)
class StopRule:
    """The stop rule for one profile.

    Attributes
    ----------
    level_tol_rad : the largest passive roll or pitch the proposal may leave [rad].
    buoyancy_half_window_N : half the width of the net-buoyancy window [N].
    stiffness_prior_Nm : the profile's W·z_g − B·z_b with z_g = 0 [N·m/rad].
    looks_s : collection times [s] at which the rule is checked.
    profile : the vehicle (its thrust curves' uncertainty).
    """

    level_tol_rad: float
    buoyancy_half_window_N: float
    stiffness_prior_Nm: float
    looks_s: tuple[float, ...]
    profile: Profile

    @classmethod
    def for_profile(cls, profile: Profile) -> StopRule:
        proc = profile.procedure
        looks = [proc.min_steady_s]
        while looks[-1] * LOOK_GROWTH < proc.collect_max_s:
            looks.append(looks[-1] * LOOK_GROWTH)
        if looks[-1] < proc.collect_max_s:
            looks.append(proc.collect_max_s)
        low, high = profile.net_buoyancy_pct
        return cls(math.radians(profile.level_tol_deg),
                   (high - low) / 200 * profile.weight_N,
                   -profile.buoyancy_N * profile.r_b_m[2], tuple(looks), profile)

    @property
    def z(self) -> float:
        """The two-sided quantile for a 1 − ALPHA decision over all looks."""
        return float(ndtri(1 - ALPHA / (2 * len(self.looks_s))))

    def row_limits(self) -> FloatArray:
        """The largest σ of a hold's mean τ row [N, N·m] that the decision tolerates, with
        the profile's stiffness (before the tilted hold there is no other)."""
        k = max(self.stiffness_prior_Nm, 1e-9)
        limits: FloatArray = np.r_[np.full(3, self.buoyancy_half_window_N),
                                   np.full(3, self.level_tol_rad * k)] / self.z
        return limits

    def hold_decided(self, hold: HoldSamples, phi: float, theta: float) -> bool:
        """Is one hold's mean effort known well enough, on the rows that carry information
        at its set-point (``phi``, ``theta``) [rad]? Used before the last hold, when no
        estimate exists yet: the residual τ − G(φ, θ)·q is taken with the profile's
        stiffness and the hold's own W − B, so attitude noise counts as it will in the
        estimate."""
        rows = informative_rows(phi, theta)
        if len(hold.t_s) < 3:
            return False
        q = np.r_[-float(np.mean(hold.tau[:, 2])), 0.0, 0.0, self.stiffness_prior_Nm]
        e = hold.tau - np.einsum("nij,j->ni", restoring_matrix(hold.phi, hold.theta), q)
        mean = mean_covariance(e[:, rows])
        sigma = np.sqrt(np.diag(mean.cov))
        # a row whose noise is already well below its thrust curves' share is as known
        # as collecting can make it (as in estimate_decided)
        limits = np.maximum(self.row_limits()[rows],
                            NOISE_SHARE * thrust_map_std(hold, rows, self.profile))
        return mean.resolved and bool(np.all(sigma <= limits))

    def estimate_decided(self, est: StaticEstimate) -> bool:
        """Are the proposal's level, its net buoyancy and the stiffness known well enough?
        Judged on the part of the ± that collecting reduces (noise, wander): each must be
        within its limit, or already at most :data:`NOISE_SHARE` of the systematic part
        (thrust curves, drift model), which stays whatever the hold's length — collecting
        on would then shrink the reported ± by at most 11 %."""
        total = np.diag(est.q_cov)
        noise = total if est.q_cov_noise is None else np.diag(est.q_cov_noise)
        k = float(est.q[3])
        if k <= 0 or not all(h.resolved for h in est.holds):
            return False
        limits = np.r_[self.buoyancy_half_window_N, self.level_tol_rad * k,
                       self.level_tol_rad * k, STIFFNESS_TOLERANCE * k] / self.z
        return bool(np.all((np.sqrt(noise) <= limits)
                           | (noise <= NOISE_SHARE**2 * (total - noise))))

    def effort_floor(self, attitude_tol_rad: float, phi: float, theta: float) -> FloatArray:
        """Effort drift [N, N·m per row of τ] too small to matter while settling at
        (``phi``, ``theta``) [rad]: half the buoyancy window for forces, and for moments
        what a tilt within the attitude tolerance changes anyway (the stiffness times
        ``attitude_tol_rad``); unbounded on rows that carry no information there (yaw at
        level). Slow wander below it is left to the estimate's long-run variance."""
        floor = np.r_[np.full(3, self.buoyancy_half_window_N),
                      np.full(3, attitude_tol_rad * self.stiffness_prior_Nm)]
        return np.where(informative_rows(phi, theta), floor, np.inf)
