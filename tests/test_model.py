"""Restoring forces, thrust configuration and thrust curves against hand computations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from trimd.model import (
    pwm_from_thrust,
    restoring_forces,
    restoring_matrix,
    tau_from_pwm,
    thrust_configuration,
    thrust_from_pwm,
)
from trimd.profile import Profile, ThrustCurve, Thruster, ThrustTable


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
