"""Shared fixtures: the shipped profiles and synthetic equilibrium holds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from trimd.core.estimate import HoldSamples
from trimd.core.model import restoring_forces
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile

REPO = Path(__file__).resolve().parent.parent
PROFILES = REPO / "trimd" / "profiles"  # the shipped profiles (package data)
ARDUSUB_LOGS = REPO / "tests" / "data" / "ardusub"  # real logs, MIT: see SOURCES.md there


@pytest.fixture(scope="session")
def sabertooth() -> Profile:
    return load_profile(PROFILES / "sabertooth-dh2.yaml")


@pytest.fixture(scope="session")
def bluerov() -> Profile:
    return load_profile(PROFILES / "bluerov2-heavy.yaml")


def payload_truth(profile: Profile, m_ext: float, r_ext: np.ndarray) -> tuple[float, np.ndarray]:
    """Weight [N] and centre of gravity [m] of the vehicle plus a point mass (CG0 = 0)."""
    W = (profile.mass_kg + m_ext) * profile.gravity_m_s2
    return W, m_ext * np.asarray(r_ext, float) / (profile.mass_kg + m_ext)


def equilibrium_holds(profile: Profile, W: float, r_g: np.ndarray, *, n: int = 200,
                      attitude_noise_deg: float = 0.0, thrust_noise: float = 0.0,
                      rng: np.random.Generator | None = None,
                      tilts_deg: tuple[tuple[float, float], ...] = ((0, 0), (20, 20)),
                      ) -> list[HoldSamples]:
    """Steady holds where τ = g(η) at the true attitude, plus optional noise.

    Attitude noise [deg] corrupts the measured roll/pitch; thrust noise is a fraction of
    the largest force (force rows) or moment (moment rows) of the hold.
    """
    rng = rng or np.random.default_rng(0)
    holds = []
    for k, (roll, pitch) in enumerate(tilts_deg):
        phi, theta = np.radians(roll), np.radians(pitch)
        tau = restoring_forces(phi, theta, W, profile.buoyancy_N, r_g, profile.r_b_m)
        scale = np.r_[np.full(3, np.abs(tau[:3]).max()), np.full(3, np.abs(tau[3:]).max())]
        noise_att = np.radians(attitude_noise_deg) * rng.standard_normal((n, 2))
        taus = tau + thrust_noise * scale * rng.standard_normal((n, 6))
        holds.append(HoldSamples(np.arange(n) * 0.1 + 100.0 * k, phi + noise_att[:, 0],
                                 theta + noise_att[:, 1], taus, f"hold {k}"))
    return holds
