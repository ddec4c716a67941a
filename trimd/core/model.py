"""Static vehicle model: restoring forces, thrust configuration and thrust curves.

Fossen (2011) notation, SI units, body frame FRD, world frame NED. Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trimd.core.curve_points import table_at, table_points
from trimd.core.profile import Profile, ThrustCurve, Thruster
from trimd.core.types import FloatArray

__all__ = [
    "INFORMATIVE",
    "band_at",
    "band_edge_thrust",
    "band_offset_sensitivity",
    "informative_rows",
    "pwm_from_thrust",
    "quaternion_from_euler",
    "restoring_forces",
    "restoring_matrix",
    "restoring_matrix_jacobian",
    "tau_from_pwm",
    "thrust_configuration",
    "thrust_from_pwm",
    "thrusts_from_pwm",
]



def restoring_matrix(phi: ArrayLike, theta: ArrayLike) -> FloatArray:
    """Matrix G(φ, θ) with g(η) = G·q, q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b].

    Fossen (2011) eq. 4.6 rearranged: the restoring forces are linear in the net vertical
    force and the three net restoring moments, which is what a static measurement sees.

    Parameters
    ----------
    phi, theta : roll and pitch [rad], scalars or arrays of the same shape ``S``.

    Returns
    -------
    G : array of shape ``S + (6, 4)``.

    Examples
    --------
    >>> restoring_matrix(0.0, 0.0)[2]   # level: Z = -(W - B)
    array([-1.,  0.,  0.,  0.])
    """
    phi_a, theta_a = np.broadcast_arrays(np.asarray(phi, float), np.asarray(theta, float))
    sp, cp = np.sin(phi_a), np.cos(phi_a)
    st, ct = np.sin(theta_a), np.cos(theta_a)
    zero = np.zeros_like(sp)
    rows = [
        [st, zero, zero, zero],
        [-ct * sp, zero, zero, zero],
        [-ct * cp, zero, zero, zero],
        [zero, zero, -ct * cp, ct * sp],
        [zero, ct * cp, zero, st],
        [zero, -ct * sp, -st, zero],
    ]
    return np.moveaxis(np.array(rows, dtype=float), (0, 1), (-2, -1))


#: A row of G(φ, θ) with no coefficient above this carries no information.
INFORMATIVE = 0.05


def informative_rows(phi: float, theta: float) -> NDArray[np.bool_]:
    """The rows of g(η) = τ that depend on q at (``phi``, ``theta``) [rad]: at level Z, K
    and M (X, Y and the yaw moment N carry nothing there: their coefficients are the sine
    of a tilt of noise size, and a thruster idle in its dead band makes their τ exactly
    zero, so such a row would claim a precision it does not have)."""
    return np.asarray(np.abs(restoring_matrix(phi, theta)).max(axis=1) > INFORMATIVE, bool)


def restoring_matrix_jacobian(phi: ArrayLike, theta: ArrayLike) -> FloatArray:
    """Partial derivatives ∂G/∂φ and ∂G/∂θ of :func:`restoring_matrix` G(φ, θ), analytic.

    The restoring forces g(η) = G·q then change with attitude as
    ∂g/∂(φ, θ) = ``np.einsum("...ijk,j->...ik", J, q)``, shape ``S + (6, 2)``
    [N or N·m per rad].

    Parameters
    ----------
    phi, theta : roll and pitch [rad], scalars or arrays of the same shape ``S``.

    Returns
    -------
    J : array of shape ``S + (6, 4, 2)`` [1/rad]; ``J[..., 0]`` is ∂G/∂φ and
        ``J[..., 1]`` is ∂G/∂θ.

    Examples
    --------
    >>> restoring_matrix_jacobian(0.0, 0.0)[0, 0]   # ∂X/∂θ = cos θ·(W − B)
    array([0., 1.])
    """
    phi_a, theta_a = np.broadcast_arrays(np.asarray(phi, float), np.asarray(theta, float))
    sp, cp = np.sin(phi_a), np.cos(phi_a)
    st, ct = np.sin(theta_a), np.cos(theta_a)
    zero = np.zeros_like(sp)
    d_phi = [
        [zero, zero, zero, zero],
        [-ct * cp, zero, zero, zero],
        [ct * sp, zero, zero, zero],
        [zero, zero, ct * sp, ct * cp],
        [zero, -ct * sp, zero, zero],
        [zero, -ct * cp, zero, zero],
    ]
    d_theta = [
        [ct, zero, zero, zero],
        [st * sp, zero, zero, zero],
        [st * cp, zero, zero, zero],
        [zero, zero, st * cp, -st * sp],
        [zero, -st * cp, zero, ct],
        [zero, st * sp, -ct, zero],
    ]
    return np.moveaxis(np.array([d_phi, d_theta], dtype=float), (0, 1, 2), (-1, -3, -2))


def restoring_forces(phi: float, theta: float, W: float, B: float,
                     r_g: ArrayLike, r_b: ArrayLike) -> FloatArray:
    """Restoring forces g(η) [N, N·m] in the body frame, Fossen (2011) eq. 4.6.

    Parameters
    ----------
    phi, theta : roll, pitch [rad].
    W, B : weight and buoyancy [N].
    r_g, r_b : centres of gravity and buoyancy [m], body FRD.

    Examples
    --------
    >>> float(restoring_forces(0.0, 0.0, 100.0, 100.0, [0.1, 0, 0], [0, 0, 0])[4])  # nose down
    10.0
    """
    r_g = np.asarray(r_g, float)
    r_b = np.asarray(r_b, float)
    q = np.concatenate([[W - B], W * r_g - B * r_b])
    g: FloatArray = restoring_matrix(phi, theta) @ q
    return g


def thrust_configuration(thrusters: Sequence[Thruster]) -> FloatArray:
    """Thrust configuration matrix T (6 × n): column i = [d_i; r_i × d_i], Fossen eq. 11.3.

    ``d_i`` is the force direction of a positive output, flipped for a reversed thruster,
    so that τ = T·f with f the thrust of each thruster [N] along its positive direction.

    In Python floats (the products and differences ``np.cross`` forms, bit for bit): the
    estimator asks for T several times per estimate, and ``np.cross`` on 3-vectors costs
    ≈ 50× more than the arithmetic.
    """
    columns = []
    for t in thrusters:
        s = -1.0 if t.reversed else 1.0
        d0, d1, d2 = (float(v) * s for v in t.direction)
        x, y, z = (float(v) for v in t.position_m)
        columns.append((d0, d1, d2, y * d2 - z * d1, z * d0 - x * d2, x * d1 - y * d0))
    T: FloatArray = np.array([[c[k] for c in columns] for k in range(6)], dtype=float
                             ).reshape(6, len(columns))
    return T


def _thrust_between(curve: ThrustCurve, k: int, pwm_us: FloatArray, w: FloatArray
                    ) -> FloatArray:
    """Thrust [N] between tables ``k`` and ``k + 1``, one voltage weight per command.

    ``pwm_us`` [µs] and ``w`` (0 at table ``k``, 1 at table ``k + 1``) have the same
    shape. Equal to ``np.interp`` on the :func:`~trimd.core.curve_points.table_at` points
    of each command's voltage, without building those points per command: the neighbours
    of each PWM on the common grid are looked up once, and a neighbour inside that
    voltage's (closed) deadband is replaced by the deadband edge at 0 N.
    """
    t0, t1 = curve.tables[k], curve.tables[k + 1]
    (p0, f0), (p1, f1) = table_points(t0), table_points(t1)
    grid = np.union1d(p0, p1)
    a, b = np.interp(grid, p0, f0), np.interp(grid, p1, f1)
    lo = t0.deadband_us[0] * (1 - w) + t1.deadband_us[0] * w
    hi = t0.deadband_us[1] * (1 - w) + t1.deadband_us[1] * w
    x = np.clip(pwm_us, grid[0], grid[-1])  # saturated at the table ends
    j = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, len(grid) - 2)
    x0, x1 = grid[j], grid[j + 1]
    y0, y1 = a[j] * (1 - w) + b[j] * w, a[j + 1] * (1 - w) + b[j + 1] * w
    below, above = x < lo, x > hi
    end = below & (x1 >= lo)  # the right neighbour is the lower deadband edge
    x1, y1 = np.where(end, lo, x1), np.where(end, 0.0, y1)
    start = above & (x0 <= hi)  # the left neighbour is the upper deadband edge
    x0, y0 = np.where(start, hi, x0), np.where(start, 0.0, y0)
    f: FloatArray = np.where(below | above, y0 + (y1 - y0) / (x1 - x0) * (x - x0), 0.0)
    return f


def thrust_from_pwm(curve: ThrustCurve, pwm_us: ArrayLike, voltage_V: ArrayLike
                    ) -> FloatArray:
    """Static thrust [N] for PWM commands [µs]; zero in the deadband, saturated at the ends.

    Parameters
    ----------
    curve : the thruster's thrust curve.
    pwm_us : PWM commands [µs], any shape.
    voltage_V : battery voltage [V]: a scalar for all commands, or an array broadcastable
        against ``pwm_us`` (one voltage per command). Between two tables the thrust is
        interpolated linearly in voltage; outside them the nearest table is used.

    Returns
    -------
    thrust : array of the broadcast shape of ``pwm_us`` and ``voltage_V`` [N].

    Examples
    --------
    >>> from trimd.core.profile import ThrustCurve, ThrustTable
    >>> c = ThrustCurve("lin", (ThrustTable(16.0, (1480, 1520), (1100, 1900), (-100, 100)),))
    >>> thrust_from_pwm(c, [1500, 1900, 2000], 16.0).tolist()
    [0.0, 100.0, 100.0]
    >>> thrust_from_pwm(c, [1900, 1900], [12.0, 16.0]).tolist()
    [100.0, 100.0]
    """
    pwm = np.asarray(pwm_us, float)
    v = np.asarray(voltage_V, float)
    if v.ndim == 0:
        f: FloatArray = np.interp(pwm, *table_at(curve, float(v)))
        return f
    pwm, v = np.broadcast_arrays(pwm, v)
    volts = np.array([t.voltage_V for t in curve.tables])
    out = np.empty(pwm.shape)
    first, last = v <= volts[0], v >= volts[-1]
    out[first] = np.interp(pwm[first], *table_points(curve.tables[0]))
    out[last] = np.interp(pwm[last], *table_points(curve.tables[-1]))
    k = np.searchsorted(volts, v) - 1  # as in table_at
    for i in range(len(volts) - 1):
        sel = ~first & ~last & (k == i)
        w = (v[sel] - volts[i]) / (volts[i + 1] - volts[i])
        out[sel] = _thrust_between(curve, i, pwm[sel], w)
    return out


def pwm_from_thrust(curve: ThrustCurve, thrust_N: ArrayLike, voltage_V: float) -> FloatArray:
    """Inverse of :func:`thrust_from_pwm`: the PWM [µs] giving each thrust [N].

    Zero thrust maps to the neutral PWM; a thrust beyond the table saturates at its end.
    """
    pwm, thrust = table_at(curve, voltage_V)
    f = np.asarray(thrust_N, float)
    zero = np.flatnonzero(thrust == 0.0)
    lo, hi = int(zero[0]), int(zero[-1])
    out = np.full(f.shape, curve.neutral_us)
    pos, neg = f > 0, f < 0
    out[pos] = np.interp(f[pos], thrust[hi:], pwm[hi:])
    out[neg] = np.interp(f[neg], thrust[:lo + 1], pwm[:lo + 1])
    return out


def tau_from_pwm(profile: Profile, pwm_us: ArrayLike, voltage_V: ArrayLike | None = None
                 ) -> FloatArray:
    """Generalised force τ [N, N·m] (body FRD) from per-thruster PWM commands [µs].

    ``pwm_us`` has shape ``(..., n_thrusters)`` in the profile's thruster order; the
    result has shape ``(..., 6)``. ``voltage_V`` [V] is a scalar, or an array
    broadcastable against ``pwm_us[..., 0]`` (one voltage per row of commands); it
    defaults to the profile's nominal voltage.
    """
    f = thrusts_from_pwm(profile, pwm_us, voltage_V)
    result: FloatArray = f @ thrust_configuration(profile.thrusters).T
    return result


def thrusts_from_pwm(profile: Profile, pwm_us: ArrayLike, voltage_V: ArrayLike | None = None
                     ) -> FloatArray:
    """Thrust f [N] of each thruster along its positive direction, from PWM commands [µs]:
    τ = T·f with T the :func:`thrust_configuration`.

    ``pwm_us`` has shape ``(..., n_thrusters)`` in the profile's thruster order, and so
    has the result; ``voltage_V`` [V] as in :func:`tau_from_pwm`.
    """
    v = profile.nominal_voltage_V if voltage_V is None else voltage_V
    pwm = np.asarray(pwm_us, float)
    if not profile.thrusters:
        return np.zeros(pwm.shape)
    f: FloatArray = np.stack([thrust_from_pwm(t.curve, pwm[..., i], v)
                              for i, t in enumerate(profile.thrusters)], axis=-1)
    return f


def band_edge_thrust(profile: Profile, voltage_V: float | None = None) -> FloatArray:
    """Per thruster, the thrust [N] of its curve ``deadband_margin_us`` beyond each edge of
    its dead band, shape (n, 2): (negative edge, positive edge), at ``voltage_V`` (default
    the profile's nominal voltage)."""
    v = profile.nominal_voltage_V if voltage_V is None else voltage_V
    edge = np.zeros((len(profile.thrusters), 2))
    for i, t in enumerate(profile.thrusters):
        lo, hi = band_at(t.curve, v)
        margin = t.curve.deadband_margin_us
        edge[i] = thrust_from_pwm(t.curve, [lo - margin, hi + margin], v)
    return edge


def band_offset_sensitivity(profile: Profile, thrust_N: ArrayLike,
                            voltage_V: float | None = None) -> FloatArray:
    """How much each thrust sample [N] would change if its thruster's dead band (its
    ESC's) started ``deadband_margin_us`` later, on the negative and on the positive side:
    shape (2, N, n) [N] for ``thrust_N`` of shape (N, n) (profile order) read through the
    curves at ``voltage_V`` (default nominal). A real ESC's band starts a few µs from the
    table's and an output inside or at the edge of the band hunts there, delivering
    whatever balances (docs/method.md §3, "The thrust map near the dead band"): a sample of
    positive thrust f at PWM p moves by the larger of f(p) − f(p − margin) and
    f(p + margin) − f(p) — the whole edge thrust near the band, the local slope times the
    margin further out — and a sample inside the
    band (exactly zero, its side unknown) by the edge thrust on either side, shared out
    as 1/√2 to each (one edge's variance in all).

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("sabertooth-dh2")
    >>> s = band_offset_sensitivity(p, [[0.0, 3.0, 100.0, -100.0, 0.0, 0.0]])
    >>> [round(float(v), 2) for v in s[1, 0, :4]], [round(float(v), 2) for v in s[0, 0, :4]]
    ([4.84, 6.84, 6.84, 0.0], [4.09, 0.0, 0.0, 5.79])
    """
    v = profile.nominal_voltage_V if voltage_V is None else voltage_V
    f = np.atleast_2d(np.asarray(thrust_N, float))
    out = np.zeros((2, *f.shape))
    edge = band_edge_thrust(profile, v)
    for i, t in enumerate(profile.thrusters):
        c, m, fi = t.curve, t.curve.deadband_margin_us, f[:, i]
        p = pwm_from_thrust(c, fi, v)
        pos, neg, zero = fi > 0, fi < 0, fi == 0
        out[1, pos, i] = np.maximum(fi[pos] - thrust_from_pwm(c, p[pos] - m, v),
                                    thrust_from_pwm(c, p[pos] + m, v) - fi[pos])
        out[0, neg, i] = np.maximum(thrust_from_pwm(c, p[neg] + m, v) - fi[neg],
                                    fi[neg] - thrust_from_pwm(c, p[neg] - m, v))
        out[1, zero, i] = edge[i, 1] / math.sqrt(2)
        out[0, zero, i] = -edge[i, 0] / math.sqrt(2)
    return out


def band_at(curve: ThrustCurve, voltage_V: float) -> tuple[float, float]:
    """The dead band (low, high) [µs] of ``curve`` at ``voltage_V``, interpolated between
    tables as the thrust is (:func:`thrust_from_pwm`)."""
    volts = [t.voltage_V for t in curve.tables]
    w = float(np.interp(voltage_V, volts, np.arange(len(volts))))
    k = min(int(w), len(volts) - 1)
    lo0, hi0 = curve.tables[k].deadband_us
    if k + 1 == len(volts):
        return lo0, hi0
    lo1, hi1 = curve.tables[k + 1].deadband_us
    f = w - k
    return lo0 * (1 - f) + lo1 * f, hi0 * (1 - f) + hi1 * f


def quaternion_from_euler(phi: float, theta: float, psi: float
                          ) -> tuple[float, float, float, float]:
    """Unit quaternion (scalar first) of ZYX Euler angles roll φ, pitch θ, yaw ψ [rad]."""
    cr, sr = math.cos(phi / 2), math.sin(phi / 2)
    cp, sp = math.cos(theta / 2), math.sin(theta / 2)
    cy, sy = math.cos(psi / 2), math.sin(psi / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)
