"""The drift of a hold that keeps depth but not station, and its Munk moment, against the
simulated vehicle (which integrates the full C_A(ν)·ν and damping, noise off)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from trimd.core.drift import drift_velocity, munk_moment
from trimd.core.profile import Profile
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.vehicle import SimVehicle


@pytest.mark.parametrize(("name", "payload", "tilt_deg"), [
    ("bluerov", "0.4@W-aft-ctr", 20.0), ("bluerov", "0.4@W-aft-ctr", -15.0),
    ("sabertooth", "10@AftSB", 20.0)])
def test_drift_and_munk_moment_match_the_simulated_vehicle(
        request: pytest.FixtureRequest, name: str, payload: str, tilt_deg: float) -> None:
    """Held at roll = pitch = tilt without station keeping, the vehicle drifts at the
    velocity the force balance gives (within 15 %: a yaw-holding thruster pair with an
    asymmetric curve adds a little surge force), and its true thrust carries g(η) plus
    the Munk moment of that drift (zero on the Sabertooth, equal added masses)."""
    profile: Profile = request.getfixturevalue(name)
    v = SimVehicle(profile, SimConfig(payload=payload, seed=2, noise=0.0))
    a = math.radians(tilt_deg)
    v.hold_attitude(a, a, 0.0)
    v.run_for(90.0)
    nu, extra, att = [], [], []
    for _ in range(300):
        v.run_for(0.1)
        nu.append(v.truth.nu[:3])
        extra.append(v.truth.tau[3:] - v.truth.g_eta[3:])
        att.append(v.truth.eta[3:5])
    phi, theta = np.mean(att, axis=0)
    net = float(v.truth.mass.net[0])
    speed = drift_velocity(profile, phi, theta, net)
    assert np.linalg.norm(speed) > 0.02                      # it does drift
    np.testing.assert_allclose(np.mean(nu, axis=0), speed, atol=0.15 * np.linalg.norm(speed))
    munk = munk_moment(profile, phi, theta, net)
    np.testing.assert_allclose(np.mean(extra, axis=0), munk,  # and 1 µm-equivalent
                               atol=0.15 * np.abs(munk).max() + 1e-6 * v.truth.mass.W)


def test_no_drift_at_level(bluerov: Profile) -> None:
    np.testing.assert_array_equal(drift_velocity(bluerov, 0.0, 0.0, 5.0), 0.0)
    np.testing.assert_array_equal(munk_moment(bluerov, 0.0, 0.0, 5.0), 0.0)
