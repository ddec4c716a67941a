"""The correction from a verify hold (issue 24): when the verify hold finds the vehicle not
level, trimd proposes what to change on the ballast installed now, from what the hold
measured. Physics, not shapes: the correction is fitted on the TRUE simulated vehicle
(the simulator's own mass properties, thrusters off), which must then float within the
profile's level tolerance or within the correction's own predicted trim ± its 95 %
interval.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.app.test_verify import verify_on_sim
from tests.helpers import SimTrim, carried, sim_trim
from trimd.ballast.changes import change_loads
from trimd.ballast.check import SlotLoad
from trimd.ballast.correct import (
    Correction,
    measured_vehicle,
    needs_correction,
    propose_correction,
)
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import Verification
from trimd.cli.main import main
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


def test_the_vehicle_as_measured_combines_the_hold_with_the_prediction(sabertooth: Profile
                                                                     ) -> None:
    """Sabertooth, 10 kg at AftSB, one foam-2kg left out: the verify hold finds it as
    predicted, so the prediction (trim + pieces) and the hold are two measurements of the
    same vehicle, and the vehicle the correction starts from is their combination — its ±
    of each level row no wider than either's and narrower than the hold's. With ballast that is
    not what was recorded (mirrored port for starboard: NOT as predicted) the prediction is
    left out and the hold stands alone."""
    payload, seed = "10@AftSB", 0
    trim = sim_trim(sabertooth, payload, seed)
    proposal, estimate = trim.result.proposal, trim.result.estimate
    assert isinstance(proposal, Proposal) and estimate is not None
    fitted = one_less(proposal.installed_after, "foam-2kg")
    loads = change_loads(sabertooth, proposal.installed, fitted)
    v = verify_on_sim(trim, payload, seed, "", loads)
    assert v.as_predicted, v.message
    vehicle = measured_vehicle(v, estimate, sabertooth)
    held, held_std = v.measured.q[:3], np.sqrt(np.diag(v.measured.q_cov))[:3]
    predicted = np.r_[-v.predicted.net_buoyancy_N, v.predicted.net_moment_Nm[:2]]
    std = np.sqrt(np.diag(vehicle.q_cov))[:3]
    assert np.all(std <= np.minimum(held_std, np.sqrt(np.diag(estimate.q_cov))[:3])), std
    assert np.all(std < held_std), (std, held_std)
    # within the narrower of the two ± of each (the rows are correlated through the
    # trim's covariance, so not necessarily between them)
    sigma = np.minimum(held_std, np.sqrt(np.diag(estimate.q_cov))[:3])
    assert np.all(np.abs(vehicle.q[:3] - held) <= sigma + np.abs(predicted - held)), (
        vehicle.q, held, predicted)
    mirrored = tuple(replace(ld, position_m=(ld.position_m[0], -ld.position_m[1],
                                             ld.position_m[2])) for ld in proposal.slots)
    wrong = verify_on_sim(trim, payload, seed, "", proposal.slots, on_vehicle=mirrored)
    assert not wrong.as_predicted, wrong.message
    alone = measured_vehicle(wrong, estimate, sabertooth)
    assert np.array_equal(alone.q[:3], wrong.measured.q[:3])
    assert np.array_equal(alone.q_cov[:3, :3], wrong.measured.q_cov[:3, :3])


@pytest.mark.slow
def test_correction_on_the_perturbed_heavy(bluerov: Profile) -> None:
    """BlueROV2 Heavy that its profile does not describe exactly (thrust curves off, dead
    bands off, realistic disturbances), its proposal fitted as proposed: wherever the
    verify hold asks for a correction, the correction leaves the TRUE vehicle within the
    tolerance or within its own 95 % interval. (Its ± is the verify hold's, which near
    level is no narrower than the trim's here: the thrusters idle at their dead bands.)"""
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
    assert corrected >= 1  # the seeds exercise the correction at all


@pytest.mark.slow
def test_the_loop_on_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                      sabertooth: Profile) -> None:
    """trim → ``ballast apply`` (one foam-2kg fewer than proposed, recorded with --set) →
    ``run --verify``: NOT level, predicted for the ballast recorded, and a ``correction``
    line; ``ballast apply --estimate`` of
    that output records the correction; ``run --verify`` again (no file: the correction
    applied since the trim) finds the vehicle level and as predicted, "no correction
    needed", and the true vehicle floats level. The history holds the chain."""
    db = str(tmp_path / "trimd.db")
    history = ["--db", db]
    common = ["--profile", "sabertooth-dh2", "--headless", "--yes", "--json", "--no-record",
              *history]

    def out() -> list[dict[str, Any]]:
        return [json.loads(x) for x in capsys.readouterr().out.splitlines()]

    def fitted(installed: list[dict[str, Any]]) -> str:
        """The sim's link with that configuration fitted (none was installed before)."""
        pieces = [InstalledPiece(x["slot"], x["piece"], x["count"]) for x in installed]
        loads = change_loads(sabertooth, (), pieces)
        return f"sim:payload=10@AftSB+{carried(loads, sabertooth.gravity_m_s2)}"

    assert main(["run", "--link", "sim:payload=10@AftSB", *common]) == 0
    trim = tmp_path / "trim.jsonl"
    trim.write_text(capsys.readouterr().out)
    proposal = json.loads(trim.read_text().splitlines()[-1])["proposal"]
    foam = next(x for x in proposal["installed_after"] if x["piece"] == "foam-2kg")
    assert main(["ballast", "apply", "--profile", "sabertooth-dh2", "--estimate", str(trim),
                 "--set", f"{foam['slot']}:foam-2kg={foam['count'] - 1}", "--json",
                 *history]) == 0
    applied = out()[-1]
    first = applied["installed"]

    assert main(["run", "--link", fitted(first), "--verify", *common]) == 0
    verify = tmp_path / "verify.jsonl"
    verify.write_text(capsys.readouterr().out)
    lines = [json.loads(x) for x in verify.read_text().splitlines()]
    v, c = lines[-2], lines[-1]
    assert v["type"] == "verification" and not v["level"], v["message"]
    # the prediction is for the ballast recorded (one foam-2kg fewer), as ``ballast
    # apply``'s physics check said, not the trim's proposal
    assert [v["predicted_roll_deg"], v["predicted_pitch_deg"]] == pytest.approx(
        [applied["predicted"]["roll_deg"], applied["predicted"]["pitch_deg"]], abs=1e-6)
    assert c["type"] == "correction" and c["needed"] and c["proposal"]["feasible"], c
    assert [x["text"] for x in c["proposal"]["changes"]] == [
        f"add 1 × foam-2kg to {foam['slot']}"]
    assert main(["ballast", "apply", "--profile", "sabertooth-dh2", "--estimate",
                 str(verify), "--json", *history]) == 0
    second = out()[-1]
    assert second["installed"] == c["proposal"]["installed_after"]

    assert main(["run", "--link", fitted(second["installed"]), "--verify", *common]) == 0
    v2, c2 = out()[-2:]
    assert v2["level"] and v2["as_predicted"], v2["message"]
    assert c2 == {"type": "correction", "needed": False, "estimate": None, "proposal": None,
                  "message": "no correction needed: level and as predicted"}
    assert main(["history", "--json", *history]) == 0
    listed = out()[0]["vehicles"][0]
    assert [len(listed[k]) for k in ("trims", "installed", "verifications", "corrections")
            ] == [1, 2, 2, 1]
    assert listed["corrections"][0]["verify_id"] == listed["verifications"][0]["id"]
    assert main(["history", *history]) == 0
    assert f"correction milp: 1 piece(s) to handle, feasible (add 1 × foam-2kg to " \
           f"{foam['slot']})" in capsys.readouterr().out
