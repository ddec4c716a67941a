"""The moment of the drift at a tilted hold of a vehicle that holds depth but not station.

In ALT_HOLD without a position sensor the horizontal thrusters get no demand: at a tilt
the vertical thrusters, which carry W − B along the tilted body z axis, also push
sideways, and the vehicle drifts until drag balances that push. A steady oblique drift ν
turns unequal added masses into a moment, the Munk moment of Fossen's C_A(ν)·ν
(docs/method.md §2): with A = diag(X_u̇, Y_v̇, Z_ẇ) (positive magnitudes) and ν = (u, v, w),

    K = (Z_ẇ − Y_v̇)·v·w,   M = (X_u̇ − Z_ẇ)·u·w,   N = (Y_v̇ − X_u̇)·u·v   [N·m],

which the thrusters carry on top of g(η). On a BlueROV2 Heavy at roll = pitch = 20° it is
≈ 0.1 mm-equivalent, 5–15 σ of a good estimate; on a stiff vehicle it is negligible.
The drift speed comes from the profile's damping (linear and quadratic, along the drift
direction), so the result is only as good as those priors.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from trimd.core.profile import Profile

__all__ = ["drift_velocity", "munk_moment"]

FloatArray = NDArray[np.float64]


def drift_velocity(profile: Profile, net_force_N: float, phi: float, theta: float
                   ) -> FloatArray:
    """Steady body velocity (u, v, w) [m/s] at roll ``phi`` and pitch ``theta`` [rad] of
    a vehicle with net weight W − B = ``net_force_N`` [N] that holds depth, not station."""
    # body z in the world (yaw 0) and its horizontal part
    z_world = np.array([math.sin(theta) * math.cos(phi), -math.sin(phi),
                        math.cos(theta) * math.cos(phi)])
    horizontal = z_world - z_world[2] * np.array([0.0, 0.0, 1.0])
    push = abs(net_force_N) / max(z_world[2], 1e-6) * float(np.linalg.norm(horizontal))
    if push == 0.0:
        return np.zeros(3)
    # the vertical thrusters push up (−z body) for a heavy vehicle, down for a light one
    sign = -1.0 if net_force_N > 0 else 1.0
    direction_world = sign * horizontal / np.linalg.norm(horizontal)
    c, s = math.cos, math.sin
    R = np.array([[c(theta), s(theta) * s(phi), s(theta) * c(phi)],
                  [0.0, c(phi), -s(phi)],
                  [-s(theta), c(theta) * s(phi), c(theta) * c(phi)]])
    u_hat = R.T @ direction_world
    lin = -np.asarray(profile.linear_damping[:3], float) @ u_hat**2
    quad = -np.asarray(profile.quadratic_damping[:3], float) @ (np.abs(u_hat) * u_hat**2)
    if quad > 0:
        speed = (-lin + math.sqrt(lin * lin + 4 * quad * push)) / (2 * quad)
    else:
        speed = push / max(lin, 1e-9)
    velocity: FloatArray = speed * u_hat
    return velocity


def munk_moment(profile: Profile, net_force_N: float, phi: float, theta: float
                ) -> FloatArray:
    """(K, M, N) [N·m] the thrusters carry against the drift's Munk moment."""
    u, v, w = drift_velocity(profile, net_force_N, phi, theta)
    a_u, a_v, a_w = profile.added_mass[:3]
    return np.array([(a_w - a_v) * v * w, (a_u - a_w) * u * w, (a_v - a_u) * u * v])
