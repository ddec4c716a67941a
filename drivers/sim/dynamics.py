"""Fossen 6-DOF rigid-body dynamics of the simulated vehicle, integrated with fixed-step RK4.

    M·ν̇ + C_RB(ν)·ν + C_A(ν_r)·ν_r + D(ν_r)·ν_r + g(η) = τ            (Fossen 2011, eq. 10.1)

with M = M_RB + M_A (eq. 3.44, 6.29 and 7.5), the rigid-body and added-mass Coriolis terms in
their Kirchhoff form C(ν)·ν = [ω × p₁; ω × p₂ + v × p₁] with (p₁, p₂) = M·ν (eq. 3.56, 6.43;
they do no work: νᵀC(ν)ν = 0), diagonal linear + quadratic damping on the velocity relative
to the water current ν_r = ν − ν_c (Fossen's derivatives are negative), and the restoring
forces of the *true* weight and buoyancy (eq. 4.6, computed from the attitude quaternion).

State ``x`` (a tuple of 13 floats): position [n, e, d] in NED [m], attitude quaternion
[q0, q1, q2, q3] (body FRD → NED, scalar first), ν = [u, v, w, p, q, r] in FRD [m/s, rad/s].
Kinematics ṗ = R(q)·v, q̇ = ½·q ⊗ (0, ω) (eq. 2.40, 2.82): no Euler singularity.

The derivative is written in scalar arithmetic on purpose: for a 6-DOF model it is several
times faster than small numpy arrays (``bench/bench_sim.py`` keeps a numpy reference).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from drivers.sim.payload import MassProperties
from trimd.model import quaternion_from_euler
from trimd.profile import Profile

__all__ = ["RigidBody", "State", "euler_from_quaternion", "initial_state"]

FloatArray = NDArray[np.float64]
State = tuple[float, ...]


def euler_from_quaternion(q0: float, q1: float, q2: float, q3: float
                          ) -> tuple[float, float, float]:
    """ZYX Euler angles (φ, θ, ψ) [rad] of a unit quaternion (scalar first).

    Examples
    --------
    >>> [round(a, 6) for a in euler_from_quaternion(*quaternion_from_euler(0.3, -0.2, 2.0))]
    [0.3, -0.2, 2.0]
    """
    s = max(-1.0, min(1.0, 2.0 * (q0 * q2 - q3 * q1)))
    return (math.atan2(2.0 * (q0 * q1 + q2 * q3), 1.0 - 2.0 * (q1 * q1 + q2 * q2)),
            math.asin(s),
            math.atan2(2.0 * (q0 * q3 + q1 * q2), 1.0 - 2.0 * (q2 * q2 + q3 * q3)))


def initial_state(depth_m: float = 0.0, phi: float = 0.0, theta: float = 0.0,
                  psi: float = 0.0, nu: Sequence[float] = (0.0,) * 6) -> State:
    """State at depth [m] and attitude [rad], with body velocity ν (default at rest)."""
    return (0.0, 0.0, depth_m, *quaternion_from_euler(phi, theta, psi), *map(float, nu))


class RigidBody:
    """The vehicle's equations of motion with its true mass properties (precomputed M⁻¹).

    Parameters
    ----------
    profile : hydrodynamics (added mass, damping) of the vehicle.
    truth : true mass, weight, buoyancy, r_g, r_b and inertia (with the payload).
    damping : False switches damping off (energy-conservation tests).
    """

    def __init__(self, profile: Profile, truth: MassProperties, *, damping: bool = True
                 ) -> None:
        m = truth.mass_kg
        self.truth = truth
        self._m = m
        self._mr = tuple(float(v) for v in m * truth.r_g)
        self._I = tuple(tuple(float(v) for v in row) for row in truth.inertia_o)
        self._A = tuple(float(v) for v in profile.added_mass)
        scale = 1.0 if damping else 0.0
        self._lin = tuple(scale * v for v in profile.linear_damping)
        self._quad = tuple(scale * v for v in profile.quadratic_damping)
        self._WB = truth.W - truth.B
        self._net = tuple(float(v) for v in truth.W * truth.r_g - truth.B * truth.r_b)
        self.M = self._mass_matrix()
        self._Minv = tuple(tuple(float(v) for v in row) for row in np.linalg.inv(self.M))

    def _mass_matrix(self) -> FloatArray:
        """M = M_RB + M_A (6 × 6) about CG0, Fossen eq. 3.44."""
        m, r_g = self._m, self.truth.r_g
        S = np.array([[0.0, -r_g[2], r_g[1]], [r_g[2], 0.0, -r_g[0]], [-r_g[1], r_g[0], 0.0]])
        M_RB = np.block([[m * np.eye(3), -m * S], [m * S, self.truth.inertia_o]])
        return M_RB + np.diag(self._A)

    def derivative(self, x: State, tau: Sequence[float], v_c: Sequence[float]) -> State:
        """ẋ for state ``x``, generalised force ``tau`` [N, N·m] (body) and water current
        ``v_c`` [m/s] (NED, irrotational: its acceleration is neglected)."""
        _, _, _, q0, q1, q2, q3, u, v, w, p, q, r = x
        # rotation body → NED
        r00 = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
        r01 = 2.0 * (q1 * q2 - q0 * q3)
        r02 = 2.0 * (q1 * q3 + q0 * q2)
        r10 = 2.0 * (q1 * q2 + q0 * q3)
        r11 = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
        r12 = 2.0 * (q2 * q3 - q0 * q1)
        r20 = 2.0 * (q1 * q3 - q0 * q2)
        r21 = 2.0 * (q2 * q3 + q0 * q1)
        r22 = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
        cn, ce, cd = v_c
        ur = u - (r00 * cn + r10 * ce + r20 * cd)
        vr = v - (r01 * cn + r11 * ce + r21 * cd)
        wr = w - (r02 * cn + r12 * ce + r22 * cd)
        # rigid-body momenta (p1, p2) = M_RB·ν
        m = self._m
        mx, my, mz = self._mr
        (Ixx, Ixy, Ixz), (Iyx, Iyy, Iyz), (Izx, Izy, Izz) = self._I
        a1 = m * u + q * mz - r * my
        a2 = m * v + r * mx - p * mz
        a3 = m * w + p * my - q * mx
        h1 = Ixx * p + Ixy * q + Ixz * r + my * w - mz * v
        h2 = Iyx * p + Iyy * q + Iyz * r + mz * u - mx * w
        h3 = Izx * p + Izy * q + Izz * r + mx * v - my * u
        # added-mass momenta on the relative velocity
        Au, Av, Aw, Ap, Aq, Ar = self._A
        b1, b2, b3 = Au * ur, Av * vr, Aw * wr
        c1, c2, c3 = Ap * p, Aq * q, Ar * r
        # restoring forces: k = gravity direction in the body frame
        WB = self._WB
        nx, ny, nz = self._net
        k1, k2, k3 = r20, r21, r22
        Lu, Lv, Lw, Lp, Lq, Lr = self._lin
        Qu, Qv, Qw, Qp, Qq, Qr = self._quad
        # τ − C_RB·ν − C_A·ν_r + (−D·ν_r) − g
        f = (
            tau[0] - (q * a3 - r * a2) - (q * b3 - r * b2)
            + (Lu + Qu * abs(ur)) * ur + WB * k1,
            tau[1] - (r * a1 - p * a3) - (r * b1 - p * b3)
            + (Lv + Qv * abs(vr)) * vr + WB * k2,
            tau[2] - (p * a2 - q * a1) - (p * b2 - q * b1)
            + (Lw + Qw * abs(wr)) * wr + WB * k3,
            tau[3] - (q * h3 - r * h2) - (v * a3 - w * a2)
            - (q * c3 - r * c2) - (vr * b3 - wr * b2)
            + (Lp + Qp * abs(p)) * p + (ny * k3 - nz * k2),
            tau[4] - (r * h1 - p * h3) - (w * a1 - u * a3)
            - (r * c1 - p * c3) - (wr * b1 - ur * b3)
            + (Lq + Qq * abs(q)) * q + (nz * k1 - nx * k3),
            tau[5] - (p * h2 - q * h1) - (u * a2 - v * a1)
            - (p * c2 - q * c1) - (ur * b2 - vr * b1)
            + (Lr + Qr * abs(r)) * r + (nx * k2 - ny * k1),
        )
        acc = tuple(row[0] * f[0] + row[1] * f[1] + row[2] * f[2] + row[3] * f[3]
                    + row[4] * f[4] + row[5] * f[5] for row in self._Minv)
        return (r00 * u + r01 * v + r02 * w, r10 * u + r11 * v + r12 * w,
                r20 * u + r21 * v + r22 * w,
                -0.5 * (q1 * p + q2 * q + q3 * r), 0.5 * (q0 * p + q2 * r - q3 * q),
                0.5 * (q0 * q - q1 * r + q3 * p), 0.5 * (q0 * r + q1 * q - q2 * p),
                *acc)

    def rk4(self, x: State, tau: Sequence[float], v_c: Sequence[float], dt: float) -> State:
        """One classical Runge–Kutta step of ``dt`` [s] with τ and current held constant;
        the quaternion is renormalised afterwards."""
        f = self.derivative
        h = 0.5 * dt
        k1 = f(x, tau, v_c)
        k2 = f(tuple(a + h * b for a, b in zip(x, k1, strict=True)), tau, v_c)
        k3 = f(tuple(a + h * b for a, b in zip(x, k2, strict=True)), tau, v_c)
        k4 = f(tuple(a + dt * b for a, b in zip(x, k3, strict=True)), tau, v_c)
        s = dt / 6.0
        y = [a + s * (b1 + 2.0 * (b2 + b3) + b4)
             for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4, strict=True)]
        norm = 1.0 / math.sqrt(y[3] * y[3] + y[4] * y[4] + y[5] * y[5] + y[6] * y[6])
        y[3:7] = [c * norm for c in y[3:7]]
        return tuple(y)

    def energy(self, x: State) -> float:
        """Kinetic plus potential energy [J]: ½·νᵀMν − W·z_CG + B·z_CB (NED z down)."""
        nu = np.asarray(x[7:13])
        q0, q1, q2, q3 = x[3:7]
        k = np.array([2.0 * (q1 * q3 - q0 * q2), 2.0 * (q2 * q3 + q0 * q1),
                      1.0 - 2.0 * (q1 * q1 + q2 * q2)])   # third row of R: world z of body axes
        t = self.truth
        potential = -t.W * (x[2] + float(k @ t.r_g)) + t.B * (x[2] + float(k @ t.r_b))
        return float(0.5 * nu @ self.M @ nu) + potential
