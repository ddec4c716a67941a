"""The correction from a verify hold (issue 24): when the verify hold finds the vehicle not
level, trimd proposes what to change on the ballast installed now, from what the hold
measured. Physics, not shapes: the correction is fitted on the TRUE simulated vehicle
(the simulator's own mass properties, thrusters off), which must then float within the
profile's level tolerance or within the correction's own predicted trim ± its 95 %
interval.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.app.test_verify import verify_on_sim
from tests.helpers import SimTrim, carried, sim_trim
from trimd.ballast.changes import change_loads
from trimd.ballast.check import SlotLoad
from trimd.ballast.correct import Correction, needs_correction, propose_correction
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import Verification
from trimd.core.profile import InstalledPiece, Profile
from trimd.drivers.sim.truth import passive_trim_deg

Z95 = 1.96


def true_trim_deg(trim: SimTrim, *loads: tuple[SlotLoad, ...]) -> np.ndarray:
    """Roll and pitch [deg] at which the TRUE vehicle of ``trim`` floats, thrusters off,
    with every one of ``loads`` fitted (in order: what was installed, then corrections)."""
    g = trim.vehicle.profile.gravity_m_s2
    extra = "+".join(filter(None, (carried(ld, g) for ld in loads)))
    return np.array(passive_trim_deg(trim.vehicle.ballasted(extra).net))


def assert_levels_as_said(profile: Profile, after: np.ndarray, c: Correction) -> None:
    """On each axis within the level tolerance or the correction's predicted trim ± 95 %."""
    t = c.proposal.trim
    predicted = np.array([t.roll_deg, t.pitch_deg])
    sigma = np.array(c.proposal.trim_std_deg)
    as_said = (np.abs(after) <= profile.level_tol_deg) | (np.abs(after - predicted)
                                                          <= Z95 * sigma)
    assert np.all(as_said), (after, predicted, sigma, c.proposal.message)


def one_less(pieces: tuple[InstalledPiece, ...], piece: str) -> tuple[InstalledPiece, ...]:
    """``pieces`` with one piece of kind ``piece`` left out (of its first slot)."""
    k = next(i for i, x in enumerate(pieces) if x.piece == piece)
    left = InstalledPiece(pieces[k].slot, piece, pieces[k].count - 1)
    return tuple(x for x in (*pieces[:k], left, *pieces[k + 1:]) if x.count > 0)


def test_correction_levels_the_true_vehicle_after_a_piece_left_out(sabertooth: Profile
                                                                  ) -> None:
    """Sabertooth, 10 kg at AftSB: the operator fits the proposal but leaves out one
    foam-2kg (and records what they did). The verify hold finds it as predicted and NOT
    level; the correction, from the ballast now on, puts the true vehicle level."""
    payload, seed = "10@AftSB", 0
    trim = sim_trim(sabertooth, payload, seed)
    proposal = trim.result.proposal
    assert isinstance(proposal, Proposal) and trim.result.estimate is not None
    fitted = one_less(proposal.installed_after, "foam-2kg")
    loads = change_loads(sabertooth, proposal.installed, fitted)
    v = verify_on_sim(trim, payload, seed, "", loads)
    assert v.as_predicted and not v.level and needs_correction(v), v.message
    c = propose_correction(v, trim.result.estimate, sabertooth, fitted)
    assert c.proposal.feasible and c.proposal.installed == fitted, c.proposal.message
    assert c.proposal.pieces_handled >= 1
    before = true_trim_deg(trim, loads)
    after = true_trim_deg(trim, loads, c.proposal.slots)
    assert np.max(np.abs(before)) > sabertooth.level_tol_deg, before
    assert_levels_as_said(sabertooth, after, c)


@pytest.mark.slow
def test_correction_on_the_perturbed_heavy(bluerov: Profile) -> None:
    """BlueROV2 Heavy that its profile does not describe exactly (thrust curves off, dead
    bands off, realistic disturbances), its proposal fitted as proposed: wherever the
    verify hold asks for a correction, the correction leaves the TRUE vehicle within the
    tolerance or within its own 95 % interval, and its ± is the verify hold's, narrower
    than the trim's proposal's."""
    payload, options = "0.4@W-aft-stbd", "disturb=real,truth=perturbed"
    corrected = 0
    for seed in range(4):
        trim = sim_trim(bluerov, payload, seed, options)
        proposal = trim.result.proposal
        assert isinstance(proposal, Proposal) and trim.result.estimate is not None
        v: Verification = verify_on_sim(trim, payload, seed, options, proposal.slots)
        if not needs_correction(v):
            continue
        corrected += 1
        c = propose_correction(v, trim.result.estimate, bluerov, proposal.installed_after)
        after = true_trim_deg(trim, proposal.slots, c.proposal.slots)
        assert_levels_as_said(bluerov, after, c)
        assert max(c.proposal.trim_std_deg) < max(proposal.trim_std_deg)
    assert corrected >= 1  # the seeds exercise the correction at all
