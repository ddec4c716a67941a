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

from trimd.core.model import quaternion_from_euler
from trimd.core.profile import Profile
from trimd.core.types import FloatArray
from trimd.drivers.sim.payload import MassProperties

__all__ = ["RigidBody", "State", "euler_from_quaternion", "initial_state"]

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
        self._I = tuple(float(v) for v in np.ravel(truth.inertia_o))   # row-major
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
        return self._rates(q0, q1, q2, q3, u, v, w, p, q, r, tau, v_c)

    def _rates(self, q0: float, q1: float, q2: float, q3: float, u: float, v: float,
               w: float, p: float, q: float, r: float, tau: Sequence[float],
               v_c: Sequence[float]) -> State:
        """ẋ of :meth:`derivative` from the attitude quaternion and ν as separate floats
        (ẋ does not depend on position; RK4 passes its stage states this way, building no
        tuples)."""
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
        # velocity relative to the water: ν_r = ν − ν_c, ν_c = Rᵀ·v_c (ν_r = ν in still water)
        cn, ce, cd = v_c
        if cn or ce or cd:
            ur = u - (r00 * cn + r10 * ce + r20 * cd)
            vr = v - (r01 * cn + r11 * ce + r21 * cd)
            wr = w - (r02 * cn + r12 * ce + r22 * cd)
        else:
            ur, vr, wr = u, v, w
        # rigid-body momenta (p1, p2) = M_RB·ν
        m = self._m
        mx, my, mz = self._mr
        Ixx, Ixy, Ixz, Iyx, Iyy, Iyz, Izx, Izy, Izz = self._I
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
        # f = τ − C_RB·ν − C_A·ν_r + (−D·ν_r) − g
        X, Y, Z, K, M, N = tau
        f0 = (X - (q * a3 - r * a2) - (q * b3 - r * b2)
              + (Lu + Qu * abs(ur)) * ur + WB * k1)
        f1 = (Y - (r * a1 - p * a3) - (r * b1 - p * b3)
              + (Lv + Qv * abs(vr)) * vr + WB * k2)
        f2 = (Z - (p * a2 - q * a1) - (p * b2 - q * b1)
              + (Lw + Qw * abs(wr)) * wr + WB * k3)
        f3 = (K - (q * h3 - r * h2) - (v * a3 - w * a2)
              - (q * c3 - r * c2) - (vr * b3 - wr * b2)
              + (Lp + Qp * abs(p)) * p + (ny * k3 - nz * k2))
        f4 = (M - (r * h1 - p * h3) - (w * a1 - u * a3)
              - (r * c1 - p * c3) - (wr * b1 - ur * b3)
              + (Lq + Qq * abs(q)) * q + (nz * k1 - nx * k3))
        f5 = (N - (p * h2 - q * h1) - (u * a2 - v * a1)
              - (p * c2 - q * c1) - (ur * b2 - vr * b1)
              + (Lr + Qr * abs(r)) * r + (nx * k2 - ny * k1))
        # ν̇ = M⁻¹·f
        g0, g1, g2, g3, g4, g5 = self._Minv
        return (r00 * u + r01 * v + r02 * w, r10 * u + r11 * v + r12 * w,
                r20 * u + r21 * v + r22 * w,
                -0.5 * (q1 * p + q2 * q + q3 * r), 0.5 * (q0 * p + q2 * r - q3 * q),
                0.5 * (q0 * q - q1 * r + q3 * p), 0.5 * (q0 * r + q1 * q - q2 * p),
                g0[0] * f0 + g0[1] * f1 + g0[2] * f2 + g0[3] * f3 + g0[4] * f4 + g0[5] * f5,
                g1[0] * f0 + g1[1] * f1 + g1[2] * f2 + g1[3] * f3 + g1[4] * f4 + g1[5] * f5,
                g2[0] * f0 + g2[1] * f1 + g2[2] * f2 + g2[3] * f3 + g2[4] * f4 + g2[5] * f5,
                g3[0] * f0 + g3[1] * f1 + g3[2] * f2 + g3[3] * f3 + g3[4] * f4 + g3[5] * f5,
                g4[0] * f0 + g4[1] * f1 + g4[2] * f2 + g4[3] * f3 + g4[4] * f4 + g4[5] * f5,
                g5[0] * f0 + g5[1] * f1 + g5[2] * f2 + g5[3] * f3 + g5[4] * f4 + g5[5] * f5)

    def rk4(self, x: State, tau: Sequence[float], v_c: Sequence[float], dt: float) -> State:
        """One classical Runge–Kutta step of ``dt`` [s] with τ and current held constant;
        the quaternion is renormalised afterwards.

        Each stage state is x + h·k on the quaternion and ν only (ẋ does not depend on
        position), passed to :meth:`_rates` as floats."""
        f = self._rates
        h = 0.5 * dt
        _, _, _, q0, q1, q2, q3, u, v, w, p, q, r = x
        k1 = f(q0, q1, q2, q3, u, v, w, p, q, r, tau, v_c)
        _, _, _, d0, d1, d2, d3, d4, d5, d6, d7, d8, d9 = k1
        k2 = f(q0 + h * d0, q1 + h * d1, q2 + h * d2, q3 + h * d3, u + h * d4, v + h * d5,
               w + h * d6, p + h * d7, q + h * d8, r + h * d9, tau, v_c)
        _, _, _, d0, d1, d2, d3, d4, d5, d6, d7, d8, d9 = k2
        k3 = f(q0 + h * d0, q1 + h * d1, q2 + h * d2, q3 + h * d3, u + h * d4, v + h * d5,
               w + h * d6, p + h * d7, q + h * d8, r + h * d9, tau, v_c)
        _, _, _, d0, d1, d2, d3, d4, d5, d6, d7, d8, d9 = k3
        k4 = f(q0 + dt * d0, q1 + dt * d1, q2 + dt * d2, q3 + dt * d3, u + dt * d4,
               v + dt * d5, w + dt * d6, p + dt * d7, q + dt * d8, r + dt * d9, tau, v_c)
        s = dt / 6.0
        n, e, d, q0, q1, q2, q3, u, v, w, p, q, r = [
            a + s * (b1 + 2.0 * (b2 + b3) + b4)
            for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4, strict=True)]
        norm = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        return (n, e, d, q0 * norm, q1 * norm, q2 * norm, q3 * norm, u, v, w, p, q, r)

    def energy(self, x: State) -> float:
        """Kinetic plus potential energy [J]: ½·νᵀMν − W·z_CG + B·z_CB (NED z down)."""
        nu = np.asarray(x[7:13])
        q0, q1, q2, q3 = x[3:7]
        k = np.array([2.0 * (q1 * q3 - q0 * q2), 2.0 * (q2 * q3 + q0 * q1),
                      1.0 - 2.0 * (q1 * q1 + q2 * q2)])   # third row of R: world z of body axes
        t = self.truth
        potential = -t.W * (x[2] + float(k @ t.r_g)) + t.B * (x[2] + float(k @ t.r_b))
        return float(0.5 * nu @ self.M @ nu) + potential
