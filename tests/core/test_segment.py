"""The one-segment fit: what one attitude determines, and its ± against the truth."""

from __future__ import annotations

import numpy as np
import pytest

from trimd.core.estimate import HoldSamples
from trimd.core.model import restoring_matrix
from trimd.core.profile_yaml import load_profile
from trimd.core.segment import estimate_segment, nominal_q

Q_TRUE = np.array([1.5, -0.2, 0.1, 0.4])


def _hold(phi: float, theta: float, rng: np.random.Generator, n: int = 600,
          noise: float = 0.0) -> HoldSamples:
    """Samples of a vehicle with net quantities Q_TRUE at (phi, theta) [rad], thruster
    effort with white noise of ``noise`` [N, N·m]."""
    tau = restoring_matrix(phi, theta) @ Q_TRUE
    return HoldSamples(np.arange(n) / 10, np.full(n, phi), np.full(n, theta),
                       tau + noise * rng.standard_normal((n, 6)))


def test_level_segment_gives_force_and_horizontal_moments_not_the_cg_height() -> None:
    p = load_profile("bluerov2-heavy")
    rng = np.random.default_rng(1)
    seg = estimate_segment(_hold(0.0, 0.0, rng, noise=0.2), p)
    assert seg.observable == (True, True, True, False)
    z = (seg.q[:3] - Q_TRUE[:3]) / seg.q_std[:3]
    assert np.all(np.abs(z) < 4), z
    assert np.isnan(seg.q_std[3])
    # the height of the CG stays at the prior: the segment says nothing about it
    assert seg.q[3] == pytest.approx(nominal_q(p)[3])


def test_level_noise_sigma_is_calibrated_over_seeds() -> None:
    """The noise part of the ± covers the truth as a 1σ should (≈ 68 %)."""
    p = load_profile("bluerov2-heavy")
    z = []
    for seed in range(40):
        seg = estimate_segment(_hold(0.0, 0.0, np.random.default_rng(seed), noise=0.3), p)
        z.append((seg.q[:3] - Q_TRUE[:3]) / np.sqrt(np.diag(seg.q_cov_noise)[:3]))
    inside = np.mean(np.abs(np.array(z)) < 1)
    assert 0.5 < inside < 0.85, inside


def test_a_tilted_segment_misses_the_moment_along_gravity() -> None:
    """At one tilted attitude the net moment along the body's vertical does not show:
    the fit is off the truth only along it (and, without station keeping, in W − B)."""
    p = load_profile("sabertooth-dh2")
    phi = theta = np.radians(20)
    seg = estimate_segment(_hold(phi, theta, np.random.default_rng(2), n=50), p,
                           q_prior=Q_TRUE + np.array([0.0, 0.3, -0.2, 0.5]))
    assert not any(seg.observable[1:])
    k_b = np.array([-np.sin(theta), np.cos(theta) * np.sin(phi), np.cos(theta) * np.cos(phi)])
    off = seg.q[1:] - Q_TRUE[1:]
    assert np.linalg.norm(off - (off @ k_b) * k_b) < 1e-9 * np.linalg.norm(Q_TRUE)
