"""Experiment design against the dead band (docs/method.md §3): after the planned holds,
a hold mirroring the tilted one is weighed, and added only when it is predicted to decide
the passive trim."""

from __future__ import annotations

import dataclasses

import numpy as np

from tests.core.test_estimate import read_through_offset_bands
from tests.helpers import equilibrium_holds, payload_truth
from trimd.core.design import plan_extra_hold, trim_spread_deg
from trimd.core.estimate import estimate_static
from trimd.core.profile import Profile


def test_a_mirrored_hold_is_added_only_when_it_is_predicted_to_decide(bluerov: Profile
                                                                      ) -> None:
    """The Heavy read through ESCs offset by up to the margin: its passive trim is known
    only to a few degrees, mostly the band's. The mirrored hold (−20°, −20°) narrows the
    prediction; with a tolerance between the two it is added, with one below both not
    (and the message says why), and with one above today's spread nothing is weighed."""
    profile = dataclasses.replace(bluerov, holds_station=True)
    W, r_g = payload_truth(profile, 0.4, np.array(profile.slot("W-aft-stbd").position_m))
    rng = np.random.default_rng(3)
    offsets = 5.0 * rng.uniform(-1, 1, (len(profile.thrusters), 2))
    holds = read_through_offset_bands(equilibrium_holds(
        profile, W, r_g, n=200, attitude_noise_deg=0.05, thrust_noise=0.02, rng=rng),
        profile, offsets)
    est = estimate_static(holds, profile)
    now, share = trim_spread_deg(est)
    assert share > 0.5
    plan = plan_extra_hold(holds, est, profile, 0.01, (20.0, 20.0))
    assert plan is not None and not plan.add and "not adding it" in plan.message
    assert (plan.roll_deg, plan.pitch_deg) == (-20.0, -20.0)
    assert plan.now_deg == now and plan.predicted_deg < now
    between = 0.5 * (plan.predicted_deg + now)
    added = plan_extra_hold(holds, est, profile, between, (20.0, 20.0))
    assert added is not None and added.add and added.message.endswith("adding it")
    assert plan_extra_hold(holds, est, profile, 1.01 * now) is None
