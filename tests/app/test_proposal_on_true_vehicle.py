"""The proposal put on the TRUE vehicle (issue 12, "the applied milp proposal"): full trims
of a simulated BlueROV2 Heavy that its profile does not describe exactly
(``truth=perturbed``: thrust curves 5 % off per thruster and direction, buoyancy 1 %,
centre of buoyancy 5 mm, each ESC's dead band up to 4 µs off, hunting at its edge) with
realistic disturbances (``disturb=real``), then the
session's milp proposal added to that true vehicle, thrusters off.

What the operator acts on is the trim the vehicle is left at, and the ± of the predicted
trim is what tells them whether to trust it. So on each of a few seeds the true trim must
be within the level tolerance or within the prediction's 95 % interval (as
:func:`tests.helpers.assert_proposal_levels` asks of one trim), and the prediction's
error/σ must not be lost in an inflated ± (its RMS over those seeds near 1). The figures
over many seeds are ``make bench``'s (bench_sim_coverage, "proposal on the true
vehicle"); measured over 59 seeds: 97 % as said, RMS 0.93 (roll) and 1.05 (pitch); with
pieces that spent the whole tolerance on their discreteness, 75 %.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import sim_trim
from trimd.ballast.propose import Proposal
from trimd.core.events import Phase
from trimd.core.profile import Profile

pytestmark = pytest.mark.slow

SEEDS = range(4)   # the first few: none picked


def test_heavy_proposal_leaves_the_true_vehicle_as_predicted(bluerov: Profile) -> None:
    after, predicted, sigma = [], [], []
    for seed in SEEDS:
        trim = sim_trim(bluerov, "0.4@W-aft-stbd", seed, "disturb=real,truth=perturbed")
        assert trim.result.phase is Phase.DONE, trim.result.reason
        proposal = trim.result.proposal
        assert isinstance(proposal, Proposal)
        after.append(trim.trim_after_proposal_deg())
        predicted.append((proposal.trim.roll_deg, proposal.trim.pitch_deg))
        sigma.append(proposal.trim_std_deg)
    a, p, s = np.array(after), np.array(predicted), np.array(sigma)
    as_said = np.all((np.abs(a) <= bluerov.level_tol_deg) | (np.abs(a - p) <= 1.96 * s), axis=1)
    assert np.all(as_said), (a[~as_said], p[~as_said], s[~as_said])
    rms = np.sqrt(np.mean(((a - p) / s) ** 2))   # over both axes of every seed
    assert 0.4 <= rms <= 1.6, rms
    # the ESC offsets (truth=perturbed) leave a Heavy's trim known only to ±1–3° at 95 %:
    # wherever the true vehicle ends beyond twice the tolerance, the proposal said it was
    # undecided (its 95 % interval wider than the tolerance: "undecided … verify")
    beyond = np.any(np.abs(a) > 2 * bluerov.level_tol_deg, axis=1)
    undecided = 1.96 * s.max(axis=1) > bluerov.level_tol_deg
    assert np.all(undecided[beyond]), (a[beyond], s[beyond])
