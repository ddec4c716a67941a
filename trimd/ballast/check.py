"""Physics check of a ballast proposal: the vehicle with the ballast added, at rest.

SI units, body frame FRD with the origin at CG0. The estimate gives the net quantities
q = [W − B, W·r_g − B·r_b] (docs/method.md §3). A ballast item at slot position r_s that
weighs w [N] and displaces b [N] of water adds w to W, b to B, w − b to q[0] and
(w − b)·r_s to the net moment m = W·r_g − B·r_b, whatever the centre-of-buoyancy prior.

Passive equilibrium: with no thruster effort the moment rows of g(η) (Fossen 2011
eq. 4.6) vanish. Those rows are d × m, with d = [−sinθ, cosθ·sinφ, cosθ·cosφ] the world
down direction in body coordinates, so the vehicle comes to rest where m points
straight down,

    φ = atan2(m_y, m_z),    θ = atan2(−m_x, √(m_y² + m_z²)),

the stable one of the two solutions of g_K = g_M = g_N = 0 (m pointing up is unstable).
It exists whatever the net vertical force W − B, which only makes the vehicle rise or
sink. A vehicle with m_z = W·z_g − B·z_b ≤ 0 (centre of gravity not below the centre of
buoyancy) has no static stability in roll and pitch: it would capsize, or with m = 0
rest at any attitude, so its passive trim is undefined. The check reports NaN angles
then (``Trim.stable`` False) rather than a meaningless number.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trimd.core.estimate import StaticEstimate
from trimd.core.types import FloatArray, Vec3

__all__ = ["MIN_GM_M", "SlotLoad", "Trim", "check_trim", "equilibrium_attitude"]

#: Metacentric height m_z/W [m] at or below which a vehicle counts as having no static
#: stability in roll and pitch (zero to rounding: a nanometre).
MIN_GM_M = 1e-9


@dataclass(frozen=True)
class SlotLoad:
    """What a proposal changes at one ballast slot: what it adds, less what it takes out
    of the ballast installed there (the measured q includes the installed ballast, so q
    plus the changes is the final configuration).

    Attributes
    ----------
    name, position_m : the slot and its position [m], body FRD.
    weight_kg : mass of the weights added [kg] (net of those removed: may be negative).
    float_kg : lift of the floats added, in water [kgf] (net, as weight_kg).
    mass_kg : dry mass of everything added, floats included [kg] (net).
    buoyancy_N : buoyancy of everything added, weights included [N] (net).
    net_down_N : its weight minus its buoyancy, in water [N] (negative: lift).
    pieces : (inventory piece name, count) pairs added; empty for ideal (continuous) ballast.
    removed : (inventory piece name, count) pairs taken out of the installed ballast.
    """

    name: str
    position_m: Vec3
    weight_kg: float
    float_kg: float
    mass_kg: float
    buoyancy_N: float
    net_down_N: float
    pieces: tuple[tuple[str, int], ...] = ()
    removed: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True, eq=False)
class Trim:
    """The vehicle with the ballast added (SI, body FRD); standard deviations are 1σ.

    ``weight_N``/``buoyancy_N`` and the centres ``r_g_m``/``r_b_m`` are the combined
    ones; ``net_moment_Nm`` = W·r_g − B·r_b after ballasting; ``roll_deg``/``pitch_deg``
    are the passive equilibrium attitude and ``*_std_deg`` their uncertainty propagated
    from the estimate's covariance of q. The four angles are NaN when the vehicle has no
    static stability (``stable`` False): its passive trim is undefined.
    """

    weight_N: float
    buoyancy_N: float
    r_g_m: FloatArray
    r_b_m: FloatArray
    net_moment_Nm: FloatArray
    roll_deg: float
    pitch_deg: float
    roll_std_deg: float
    pitch_std_deg: float
    net_buoyancy_std_N: float

    @property
    def net_buoyancy_N(self) -> float:
        """B − W [N]: positive when the vehicle floats up."""
        return self.buoyancy_N - self.weight_N

    @property
    def stable(self) -> bool:
        """Whether W·z_g − B·z_b > 0 (above :data:`MIN_GM_M` × W): a passive trim exists."""
        return bool(self.net_moment_Nm[2] > MIN_GM_M * self.weight_N)

    @property
    def net_buoyancy_pct(self) -> float:
        """B − W as a percentage of the combined weight W."""
        return 100.0 * self.net_buoyancy_N / self.weight_N


def equilibrium_attitude(m: FloatArray, min_mz_Nm: float = 0.0
                         ) -> tuple[tuple[float, float], FloatArray] | None:
    """Stable passive roll and pitch [rad] for the net moment m = W·r_g − B·r_b [N·m].

    Returns
    -------
    ((phi, theta), J) : the attitude where g_K = g_M = g_N = 0 and m points down, and the
        2 × 3 Jacobian ∂(φ, θ)/∂m [rad/(N·m)].
    None : when m_z ≤ ``min_mz_Nm`` [N·m]: no static stability, no passive trim.

    Examples
    --------
    >>> (phi, theta), _ = equilibrium_attitude(np.array([-1.0, 0.0, 1.0]))  # nose-light
    >>> round(float(np.degrees(phi)), 6), round(float(np.degrees(theta)), 6)
    (0.0, 45.0)
    >>> equilibrium_attitude(np.zeros(3)) is None
    True
    """
    mx, my, mz = (float(v) for v in m)
    if not mz > max(min_mz_Nm, 0.0):
        return None
    rho2 = my * my + mz * mz
    n2 = rho2 + mx * mx
    rho = math.sqrt(rho2)
    J = np.array([[0.0, mz / rho2, -my / rho2],
                  [-rho / n2, mx * my / (rho * n2), mx * mz / (rho * n2)]])
    return (math.atan2(my, mz), math.atan2(-mx, rho)), J


def check_trim(estimate: StaticEstimate, loads: Sequence[SlotLoad],
               gravity_m_s2: float) -> Trim:
    """Combined weight, buoyancy, centres and passive attitude with ``loads`` added: the
    final configuration (the estimate already includes the ballast installed when it was
    measured; a load's removals are negative).

    The attitude and its uncertainty come from the net quantities q and their
    covariance alone; the centres use the estimate's W, B and r_b for reporting.
    """
    r = np.array([ld.position_m for ld in loads], dtype=float).reshape(-1, 3)
    w = np.array([ld.mass_kg for ld in loads], dtype=float) * gravity_m_s2
    b = np.array([ld.buoyancy_N for ld in loads], dtype=float)
    W = estimate.weight_N + float(w.sum())
    B = estimate.buoyancy_N + float(b.sum())
    r_g = (estimate.weight_N * estimate.r_g_m + w @ r) / W
    r_b = (estimate.buoyancy_N * estimate.r_b_m + b @ r) / B
    m = estimate.q[1:] + (w - b) @ r
    attitude = equilibrium_attitude(m, MIN_GM_M * W)
    if attitude is None:
        angles, std = np.full(2, np.nan), np.full(2, np.nan)
    else:
        angles, J = np.degrees(attitude[0]), attitude[1]
        std = np.degrees(np.sqrt(np.clip(np.diag(J @ estimate.q_cov[1:, 1:] @ J.T), 0.0, None)))
    return Trim(weight_N=W, buoyancy_N=B, r_g_m=r_g, r_b_m=r_b, net_moment_Nm=m,
                roll_deg=float(angles[0]), pitch_deg=float(angles[1]),
                roll_std_deg=float(std[0]), pitch_std_deg=float(std[1]),
                net_buoyancy_std_N=math.sqrt(max(float(estimate.q_cov[0, 0]), 0.0)))
