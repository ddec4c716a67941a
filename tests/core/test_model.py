"""Restoring forces, thrust configuration and thrust curves against hand computations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from trimd.core.model import (
    pwm_from_thrust,
    restoring_forces,
    restoring_matrix,
    restoring_matrix_jacobian,
    tau_from_pwm,
    thrust_configuration,
    thrust_from_pwm,
)
from trimd.core.profile import Profile, ThrustCurve, Thruster, ThrustTable


def test_level_restoring_forces_by_hand() -> None:
    # W = 100 N at (0.1, 0.2, 0.3), B = 90 N at (0, 0, -0.1), level
    g = restoring_forces(0.0, 0.0, 100.0, 90.0, [0.1, 0.2, 0.3], [0.0, 0.0, -0.1])
    np.testing.assert_allclose(g, [0.0, 0.0, -10.0, -20.0, 10.0, 0.0], atol=1e-12)


def test_rolled_restoring_forces_by_hand() -> None:
    # φ = 30°, θ = 0, W = B = 100 N, r_g = (0, 0, 0.05), r_b = 0: righting moment
    # K = z_g·W·sinφ = 0.05·100·0.5 = 2.5 N·m
    g = restoring_forces(np.radians(30), 0.0, 100.0, 100.0, [0, 0, 0.05], [0, 0, 0])
    np.testing.assert_allclose(g, [0, 0, 0, 2.5, 0, 0], atol=1e-12)


def test_pitched_restoring_forces_by_hand() -> None:
    # θ = 90°: X = W − B; M = z_g·W·1 − z_b·B; N = −(y_g·W − y_b·B)
    g = restoring_forces(0.0, np.pi / 2, 10.0, 4.0, [0.0, 0.5, 0.2], [0.0, 0.0, -0.1])
    np.testing.assert_allclose(g, [6.0, 0, 0, 0, 2.0 + 0.4, -5.0], atol=1e-12)


@given(phi=st.floats(-1.2, 1.2), theta=st.floats(-1.2, 1.2), W=st.floats(1, 1e4),
       B=st.floats(1, 1e4), r=st.lists(st.floats(-1, 1), min_size=6, max_size=6))
def test_restoring_matrix_is_the_restoring_force(phi: float, theta: float, W: float,
                                                 B: float, r: list[float]) -> None:
    r_g, r_b = np.array(r[:3]), np.array(r[3:])
    q = np.r_[W - B, W * r_g - B * r_b]
    np.testing.assert_allclose(restoring_matrix(phi, theta) @ q,
                               restoring_forces(phi, theta, W, B, r_g, r_b), atol=1e-8)


@given(phi=st.floats(-1.2, 1.2), theta=st.floats(-1.2, 1.2))
def test_mirror_symmetry_in_roll(phi: float, theta: float) -> None:
    """A port/starboard mirror image (y → −y, φ → −φ) mirrors Y, K and N."""
    r_g, r_b = np.array([0.1, 0.2, 0.05]), np.array([0.0, -0.1, -0.02])
    mirror = np.array([1, -1, 1])
    a = restoring_forces(phi, theta, 50.0, 48.0, r_g, r_b)
    b = restoring_forces(-phi, theta, 50.0, 48.0, r_g * mirror, r_b * mirror)
    np.testing.assert_allclose(b, a * np.array([1, -1, 1, -1, 1, -1]), atol=1e-10)


def test_restoring_matrix_broadcasts() -> None:
    G = restoring_matrix(np.zeros(5), np.linspace(0, 0.3, 5))
    assert G.shape == (5, 6, 4)
    np.testing.assert_allclose(G[3], restoring_matrix(0.0, 0.225))


def test_restoring_matrix_jacobian_matches_central_differences() -> None:
    rng = np.random.default_rng(11)
    h = 1e-6
    for phi, theta in rng.uniform(-np.radians(60), np.radians(60), (20, 2)):
        J = restoring_matrix_jacobian(phi, theta)
        d_phi = (restoring_matrix(phi + h, theta) - restoring_matrix(phi - h, theta)) / (2 * h)
        d_theta = (restoring_matrix(phi, theta + h) - restoring_matrix(phi, theta - h)) / (2 * h)
        np.testing.assert_allclose(J[..., 0], d_phi, rtol=0, atol=1e-9)
        np.testing.assert_allclose(J[..., 1], d_theta, rtol=0, atol=1e-9)


def test_restoring_matrix_jacobian_broadcasts() -> None:
    phi, theta = np.linspace(-0.5, 0.5, 5), np.linspace(0, 0.3, 5)
    J = restoring_matrix_jacobian(phi, theta)
    assert J.shape == (5, 6, 4, 2)
    np.testing.assert_allclose(J[3], restoring_matrix_jacobian(phi[3], theta[3]))


def test_thrust_configuration_columns() -> None:
    curve = ThrustCurve("lin", (ThrustTable(16.0, (1500, 1500), (1100, 1900), (-10, 10)),))
    t = Thruster("a", 1, (1.0, 0.5, 0.0), (0.0, 0.0, 1.0), curve)
    rev = Thruster("b", 2, (1.0, 0.5, 0.0), (0.0, 0.0, 1.0), curve, reversed=True)
    T = thrust_configuration([t, rev])
    # r × d = (0.5·1 − 0, 0 − 1·1, 0) = (0.5, −1, 0)
    np.testing.assert_allclose(T[:, 0], [0, 0, 1, 0.5, -1, 0])
    np.testing.assert_allclose(T[:, 1], -T[:, 0])


def test_t200_curve_at_table_voltages_and_between(bluerov: Profile) -> None:
    curve = bluerov.thrusters[0].curve
    kgf = 9.80665
    assert thrust_from_pwm(curve, [1900], 16.0)[0] == pytest.approx(5.25 * kgf)
    assert thrust_from_pwm(curve, [1100], 12.0)[0] == pytest.approx(-2.90 * kgf)
    assert thrust_from_pwm(curve, [1500, 1470, 1530], 12.0).tolist() == [0.0, 0.0, 0.0]
    # 14 V: halfway between the 12 V and 16 V tables
    assert thrust_from_pwm(curve, [1800], 14.0)[0] == pytest.approx((2.46 + 3.42) / 2 * kgf)
    # the deadband edge at 16 V is 1528 µs: 1530 already pushes
    assert thrust_from_pwm(curve, [1530], 16.0)[0] > 0
    assert thrust_from_pwm(curve, [2000], 16.0)[0] == pytest.approx(5.25 * kgf)


@given(f=st.floats(-35.0, 50.0), v=st.floats(12.0, 16.0))
def test_pwm_from_thrust_inverts_the_curve(bluerov: Profile, f: float, v: float) -> None:
    curve = bluerov.thrusters[0].curve
    pwm = pwm_from_thrust(curve, [f], v)
    lo, hi = thrust_from_pwm(curve, [1100, 1900], v)
    assert thrust_from_pwm(curve, pwm, v)[0] == pytest.approx(np.clip(f, lo, hi), abs=1e-6)
    if f == 0:
        assert pwm[0] == 1500


def test_tau_from_pwm_uses_geometry(bluerov: Profile) -> None:
    pwm = np.full(8, 1500.0)
    pwm[4:] = 1700  # all four verticals push down equally
    tau = tau_from_pwm(bluerov, pwm, 16.0)
    np.testing.assert_allclose(tau, [0, 0, 4 * 1.82 * 9.80665, 0, 0, 0], atol=1e-9)
    many = tau_from_pwm(bluerov, np.tile(pwm, (3, 1)), 16.0)
    assert many.shape == (3, 6)


def test_thrust_from_pwm_with_one_voltage_per_command() -> None:
    """Three tables on different PWM grids, so that grid points fall inside the deadband
    interpolated between two tables; voltages below, between, at and above the tables."""
    curve = ThrustCurve("three", (
        ThrustTable(12.0, (1460, 1540), (1100, 1300, 1450, 1550, 1700, 1900),
                    (-20, -8, -1, 1.5, 12, 25)),
        ThrustTable(14.0, (1480, 1520), (1100, 1250, 1470, 1530, 1650, 1800, 1900),
                    (-28, -15, -0.5, 0.7, 14, 27, 33)),
        ThrustTable(16.0, (1490, 1510), (1150, 1400, 1495, 1505, 1600, 1850),
                    (-30, -12, -0.2, 0.3, 20, 40)),
    ))
    rng = np.random.default_rng(5)
    pwm = np.r_[rng.uniform(1000, 2000, 600), [1100, 1250, 1460, 1470, 1500, 1530, 1540, 1900]]
    volts = np.r_[rng.uniform(11, 17, 600), [12.0, 13.0, 14.0, 15.0, 16.0, 11.0, 17.0, 12.5]]
    loop = [thrust_from_pwm(curve, [p], v)[0] for p, v in zip(pwm, volts, strict=True)]
    np.testing.assert_allclose(thrust_from_pwm(curve, pwm, volts), loop, rtol=1e-12, atol=1e-12)
    # one voltage broadcast over a grid of commands, and a 0-d voltage
    grid = thrust_from_pwm(curve, pwm[:5, None], volts[None, :7])
    assert grid.shape == (5, 7)
    np.testing.assert_allclose(grid[2, 4], thrust_from_pwm(curve, [pwm[2]], volts[4])[0])
    np.testing.assert_allclose(thrust_from_pwm(curve, pwm, np.float64(13.0)),
                               thrust_from_pwm(curve, pwm, np.full(pwm.shape, 13.0)),
                               rtol=1e-12, atol=1e-12)
    # at 13 V the deadband is [1470, 1530], both edges points of the 14 V table: still 0 N
    band = np.linspace(1470, 1530, 13)
    assert thrust_from_pwm(curve, band, 13.0).tolist() == [0.0] * 13
    assert thrust_from_pwm(curve, band, np.full(13, 13.0)).tolist() == [0.0] * 13


def test_tau_from_pwm_with_one_voltage_per_row(bluerov: Profile) -> None:
    rng = np.random.default_rng(8)
    n = 500
    pwm = rng.uniform(1000, 2000, (n, len(bluerov.thrusters)))
    pwm[::10] = 1500.0  # all in the deadband
    volts = rng.uniform(11.0, 17.0, n)
    volts[::7] = 14.0
    loop = np.array([tau_from_pwm(bluerov, p, v) for p, v in zip(pwm, volts, strict=True)])
    tau = tau_from_pwm(bluerov, pwm, volts)
    assert tau.shape == (n, 6)
    np.testing.assert_allclose(tau, loop, rtol=1e-12, atol=1e-9)
    # a scalar voltage (or none: the nominal one) still applies to every row
    np.testing.assert_allclose(tau_from_pwm(bluerov, pwm, 13.0),
                               tau_from_pwm(bluerov, pwm, np.full(n, 13.0)), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(tau_from_pwm(bluerov, pwm),
                               tau_from_pwm(bluerov, pwm, bluerov.nominal_voltage_V))
