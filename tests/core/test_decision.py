"""The stop rule judges the part of the ± that collecting reduces."""

from __future__ import annotations

import dataclasses

import numpy as np

from tests.core.test_estimate import read_through_wrong_curves, with_thrust_uncertainty
from tests.helpers import equilibrium_holds, payload_truth
from trimd.core.decision import StopRule
from trimd.core.estimate import estimate_static
from trimd.core.profile import Profile


def test_collecting_stops_once_the_systematic_part_dominates(sabertooth: Profile) -> None:
    """Noise too large for the level tolerance: with exact thrust curves the rule waits
    for more samples; with the curves' 5 % (a ± no hold length shrinks) larger than the
    noise, collecting on would not make the proposal known better, so it stops."""
    profile = dataclasses.replace(sabertooth, holds_station=True)
    W, r_g = payload_truth(profile, 10.0, np.array(profile.slot("AftSB").position_m))
    holds = read_through_wrong_curves(equilibrium_holds(
        profile, W, r_g, n=100, attitude_noise_deg=0.05, thrust_noise=0.1,
        rng=np.random.default_rng(1)), profile, np.zeros((len(profile.thrusters), 2)))
    rule = StopRule.for_profile(profile)
    exact = estimate_static(holds, with_thrust_uncertainty(profile, 0.0))
    uncertain = estimate_static(holds, profile)
    assert uncertain.q_cov_noise is not None
    limit = rule.level_tol_rad * uncertain.q[3] / rule.z
    assert np.sqrt(uncertain.q_cov_noise[1, 1]) > limit   # the noise alone is too much
    assert not rule.estimate_decided(exact)
    assert rule.estimate_decided(uncertain)
