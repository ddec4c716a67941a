"""The steady drift of a hold that keeps depth but not station, and the Munk moment of it.

Without a position fix (ArduSub's ALT_HOLD without a DVL) a hold keeps attitude and depth
but gives the horizontal thrusters no demand: body X and Y thrust are zero. At a tilt the
body-horizontal part of the net weight W − B then pushes the vehicle until drag balances
it (Fossen (2011) eq. 6.2 at rest in rotation, ν₂ = 0):

    d_u(u)·u = −g_X(η) = −sin θ·(W − B),    d_v(v)·v = −g_Y(η) = cos θ·sin φ·(W − B),

with d(x) = −X_u − X_u|u|·|x| > 0 from the profile's (negative) damping derivatives, and
the heave w such that the depth does not change:
−sin θ·u + cos θ·sin φ·v + cos θ·cos φ·w = 0. Unequal added masses turn that oblique
drift into a moment, the moment part of C_A(ν)·ν at ν₂ = 0 (the Munk moment):

    ν₁ × (M_A·ν₁) = [(a_w − a_v)·v·w, (a_u − a_w)·u·w, (a_v − a_u)·u·v]   [N·m]

(a_u, a_v, a_w the added-mass magnitudes). The thrusters carry it on top of g(η), so a
drifting hold's moment rows read g(η) plus this. Units: N, m/s, N·m; body FRD.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from trimd.core.profile import Profile

__all__ = ["DRIFT_MODEL_ERROR", "drift_velocity", "munk_moment"]

#: The relative 1σ error of the modelled Munk moment: profile damping and added mass are
#: rough (±30–50 % is usual), and a tether or a current changes the drift.
DRIFT_MODEL_ERROR = 0.5


def _speed(force_N: float, linear: float, quadratic: float) -> float:
    """x [m/s] with (−linear − quadratic·|x|)·x = force_N (damping derivatives ≤ 0)."""
    lin, quad = -linear, -quadratic
    if force_N == 0:
        return 0.0
    if quad > 0:
        x = (-lin + math.sqrt(lin * lin + 4 * quad * abs(force_N))) / (2 * quad)
    elif lin > 0:
        x = abs(force_N) / lin
    else:
        return math.inf  # no damping: no steady drift
    return math.copysign(x, force_N)


def drift_velocity(profile: Profile, phi: float, theta: float, net_weight_N: float
                   ) -> NDArray[np.float64]:
    """Body velocity (u, v, w) [m/s] of the steady drift at roll ``phi``, pitch ``theta``
    [rad] for the net weight W − B ``net_weight_N`` [N], depth held, station not; inf
    where the profile has no damping on that axis."""
    lin, quad = profile.linear_damping, profile.quadratic_damping
    u = _speed(-math.sin(theta) * net_weight_N, lin[0], quad[0])
    v = _speed(math.cos(theta) * math.sin(phi) * net_weight_N, lin[1], quad[1])
    w = (math.sin(theta) * u - math.cos(theta) * math.sin(phi) * v) / (
        math.cos(theta) * math.cos(phi))
    return np.array([u, v, w])


def munk_moment(profile: Profile, phi: float, theta: float, net_weight_N: float
                ) -> NDArray[np.float64]:
    """The Munk moment [N·m] (K, M, N) of the steady drift of :func:`drift_velocity`."""
    u, v, w = drift_velocity(profile, phi, theta, net_weight_N)
    a_u, a_v, a_w = profile.added_mass[:3]
    return np.array([(a_w - a_v) * v * w, (a_u - a_w) * u * w, (a_v - a_u) * u * v])
