"""The static estimate: the weight, centre of gravity and payload that a fit of the net
quantities q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] gives on a profile
(:func:`net_estimate`), with what each hold contributed (:class:`HoldSummary`).

:func:`trimd.core.estimate.estimate_static` fits q from the holds;
:mod:`trimd.ballast.correct` turns a corrected q into the same result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from trimd.core.errors import EstimationError
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

__all__ = ["HoldSummary", "StaticEstimate", "net_estimate"]



@dataclass(frozen=True)
class HoldSummary:
    """What one hold contributed: mean attitude [deg], sample count, window [s], and how
    many independent samples they were worth (``effective_samples``); ``resolved`` is
    False when the hold was too short for its own correlation time (its ± is then likely
    too small: hold longer)."""

    label: str
    roll_deg: float
    pitch_deg: float
    samples: int
    t_start_s: float
    t_end_s: float
    effective_samples: float = math.nan
    resolved: bool = True


@dataclass(frozen=True, eq=False)
class StaticEstimate:
    """Result of :func:`trimd.core.estimate.estimate_static` (SI units, body FRD).

    ``q``/``q_cov`` are the net quantities [W − B, W·r_g − B·r_b] and their covariance;
    ``cov`` is the covariance of [W, x_g, y_g, z_g] (N, m). Standard deviations are 1σ.
    ``q_cov_noise`` is the part of ``q_cov`` that collecting longer reduces (noise and
    wander); the rest is systematic (thrust curves, drift model). None: all of it.
    ``q_cov_band`` is the part from thrusters at or near their dead band (ESC offsets);
    ``notes`` say, for people, which rows and quantities rest on such thrusters.
    """

    q: FloatArray
    q_cov: FloatArray
    weight_N: float
    buoyancy_N: float
    r_b_m: FloatArray
    r_g_m: FloatArray
    cov: FloatArray
    m_ext_kg: float
    gravity_m_s2: float
    holds: tuple[HoldSummary, ...]
    dofs_used: tuple[str, ...]
    residual_rms: FloatArray = field(repr=False)
    success: bool = True
    message: str = "ok"
    q_cov_noise: FloatArray | None = field(default=None, repr=False)
    q_cov_band: FloatArray | None = field(default=None, repr=False)
    notes: tuple[str, ...] = ()

    @property
    def weight_std_N(self) -> float:
        return float(np.sqrt(self.cov[0, 0]))

    @property
    def m_ext_std_kg(self) -> float:
        return self.weight_std_N / self.gravity_m_s2

    @property
    def r_g_std_m(self) -> FloatArray:
        return np.sqrt(np.diag(self.cov)[1:])

    @property
    def net_moment_Nm(self) -> FloatArray:
        """W·r_g − B·r_b [N·m]: independent of the profile's centre-of-buoyancy prior."""
        return self.q[1:].copy()

    @property
    def net_moment_std_Nm(self) -> FloatArray:
        return np.sqrt(np.diag(self.q_cov)[1:])


def net_estimate(q: FloatArray, q_cov: FloatArray, profile: Profile, *,
                 holds: tuple[HoldSummary, ...], dofs_used: tuple[str, ...],
                 residual_rms: FloatArray, notes: tuple[str, ...] = (),
                 q_cov_noise: FloatArray | None = None,
                 q_cov_band: FloatArray | None = None) -> StaticEstimate:
    """The estimate of the net quantities ``q`` = [W − B, W·r_g − B·r_b] [N, N·m] (body
    FRD, origin CG0) with covariance ``q_cov`` on ``profile``: W = q₀ + B and
    r_g = (q₁₋₃ + B·r_b)/W with the profile's B and r_b, their covariance by the Jacobian.

    Raises
    ------
    EstimationError : W ≤ 0.
    """
    B, r_b = profile.buoyancy_N, np.asarray(profile.r_b_m, float)
    W = float(q[0] + B)
    if W <= 0:
        raise EstimationError(f"estimated weight {W:.1f} N is not positive: check the thrust "
                              "signs and the profile's buoyancy")
    r_g = (q[1:] + B * r_b) / W
    J = np.zeros((4, 4))
    J[0, 0] = 1.0
    J[1:, 0] = -r_g / W
    J[1:, 1:] = np.eye(3) / W
    return StaticEstimate(
        q=q, q_cov=q_cov, weight_N=W, buoyancy_N=B, r_b_m=r_b, r_g_m=r_g,
        cov=J @ q_cov @ J.T, m_ext_kg=W / profile.gravity_m_s2 - profile.mass_kg,
        gravity_m_s2=profile.gravity_m_s2, holds=holds, dofs_used=dofs_used,
        residual_rms=residual_rms, q_cov_noise=q_cov_noise, q_cov_band=q_cov_band,
        notes=notes)
