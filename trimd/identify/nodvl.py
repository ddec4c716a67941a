"""Experiments without a DVL: surge and sway velocities from a surge and sway model, heave from
the depth rate.

Without body velocity the gyro and attitude still observe roll, pitch and yaw, and the
depth sensor heave — but the coupling terms of those DOFs (the Munk moment
(M_w − M_u)·u·w, the Coriolis forces) and the depth rate itself
(ż = −sin θ·u + cos θ·sin φ·v + cos θ·cos φ·w) involve surge and sway. Their velocities
are estimated by simulating surge and sway alone from the commanded thrust with the
given parameters (a free run from rest; the other states measured), and the heave
velocity is then w = (ż + sin θ·u − cos θ·sin φ·v)/(cos θ·cos φ); twice, so that w and
u, v agree. The fit (:func:`trimd.identify.fit.fit_stage`) calls it first with the
profile's surge and sway, then with the ones it fitted as nuisance parameters: these
estimates start each simulated segment and give the heave velocity, the fit's own
simulation of surge and sway carries u, v into the coupling terms.

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from trimd.core.types import FloatArray
from trimd.identify.data import Experiment, depth_rate
from trimd.identify.model import HYDRO_NAMES, LAG, lagged_thrust

__all__ = ["with_estimated_velocity"]



def with_estimated_velocity(experiments: Sequence[Experiment], values: Mapping[str, float],
                            mass_kg: float, q_rest: FloatArray) -> list[Experiment]:
    """``experiments`` with u, v and w estimated where they have no DVL (module docstring);
    ``values``: the hydrodynamic parameters (and ``T_thr``) of the model, ``mass_kg`` and
    ``q_rest`` the fixed mass and restoring terms. Experiments with a DVL are returned
    unchanged."""
    out = []
    for e in experiments:
        if e.dvl:
            out.append(e)
            continue
        z_dot = depth_rate(e.eta, e.h_s, e.interval_s(2))
        nu = e.nu.copy()
        for _ in range(2):
            nu[:, :2] = _surge_sway(e, nu, values, mass_kg, q_rest)
            phi, theta = e.eta[:, 3], e.eta[:, 4]
            nu[:, 2] = ((z_dot + np.sin(theta) * nu[:, 0]
                         - np.cos(theta) * np.sin(phi) * nu[:, 1])
                        / (np.cos(theta) * np.cos(phi)))
        out.append(dataclasses.replace(e, nu=nu))
    return out


def _surge_sway(e: Experiment, nu: FloatArray, values: Mapping[str, float], mass_kg: float,
                q_rest: FloatArray) -> FloatArray:
    """u, v [m/s] of a free-run RK4 simulation of surge and sway from rest (Fossen's
    equations of docs/method.md §2 for those two DOFs, the other states from ``nu`` and
    the attitude, held over each step), (N, 2)."""
    Mu, Mv = mass_kg + values[HYDRO_NAMES[0]], mass_kg + values[HYDRO_NAMES[1]]
    Mw = mass_kg + values[HYDRO_NAMES[2]]
    Xu, Yv = values[HYDRO_NAMES[6]], values[HYDRO_NAMES[7]]
    Xuu, Yvv = values[HYDRO_NAMES[12]], values[HYDRO_NAMES[13]]
    tau = lagged_thrust(e.tau, values.get(LAG, 0.0), e.h_s)[0]
    st, ct = np.sin(e.eta[:, 4]), np.cos(e.eta[:, 4])
    sp = np.sin(e.eta[:, 3])
    q0 = float(q_rest[0])
    # per sample: the force on surge and sway that does not depend on u, v
    fx = (tau[:, 0] - nu[:, 4] * Mw * nu[:, 2] - st * q0).tolist()
    fy = (tau[:, 1] + nu[:, 3] * Mw * nu[:, 2] + ct * sp * q0).tolist()
    r = nu[:, 5].tolist()
    h = e.h_s

    def f(k: int, u: float, v: float) -> tuple[float, float]:
        # Kirchhoff: −(q·M_w·w − r·M_v·v) on surge, −(r·M_u·u − p·M_w·w) on sway
        return ((fx[k] + r[k] * Mv * v + (Xu + Xuu * abs(u)) * u) / Mu,
                (fy[k] - r[k] * Mu * u + (Yv + Yvv * abs(v)) * v) / Mv)

    u = v = 0.0
    out = np.empty((len(fx), 2))
    for k in range(len(fx)):
        out[k] = u, v
        a1, b1 = f(k, u, v)
        a2, b2 = f(k, u + 0.5 * h * a1, v + 0.5 * h * b1)
        a3, b3 = f(k, u + 0.5 * h * a2, v + 0.5 * h * b2)
        a4, b4 = f(k, u + h * a3, v + h * b3)
        u += h / 6.0 * (a1 + 2.0 * (a2 + a3) + a4)
        v += h / 6.0 * (b1 + 2.0 * (b2 + b3) + b4)
    return out
