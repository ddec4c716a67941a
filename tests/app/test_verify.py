"""The verify hold (issue 15): after the proposal's ballast is on the simulated vehicle, one
level hold measures what it left and compares it with the prediction.

Physics, not shapes: the verify hold's measured passive trim must match the TRUE
ballasted vehicle's (the simulator's own equilibrium) within the verification's 95 %
interval and lie within the proposal's predicted trim ± its 95 % interval, and a wrongly
installed ballast must be told apart from the right one.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import SimTrim, carried, equilibrium_holds, sim_trim, sim_verify
from trimd.app.report import undecided_advice
from trimd.ballast.check import SlotLoad
from trimd.ballast.propose import Proposal, proposal_to_dict
from trimd.ballast.verify import Verification
from trimd.cli.main import main
from trimd.core.estimate import estimate_static
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.events import Phase
from trimd.core.floating import Z95 as FLOAT_Z95
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.payload import mass_properties

Z95 = 1.96


def verify_on_sim(trim: SimTrim, payload: str, seed: int, options: str,
                  installed: tuple[SlotLoad, ...], on_vehicle: tuple[SlotLoad, ...] | None = None
                  ) -> Verification:
    """The verify hold of ``installed`` (the ballast the operator says is on) on the
    simulated vehicle carrying ``payload`` and ``on_vehicle`` (default: ``installed``)."""
    assert trim.result.estimate is not None
    result = sim_verify(trim.vehicle.profile, payload, seed, options, trim.result.estimate,
                        installed, on_vehicle).result
    assert result.phase is Phase.DONE, result.reason
    assert isinstance(result.verification, Verification)
    return result.verification


@pytest.mark.slow
def test_verify_hold_measures_what_the_ballast_left(bluerov: Profile) -> None:
    """BlueROV2 Heavy that its profile does not describe exactly, realistic disturbances.
    Its ESCs' bands are off (truth=perturbed), and near level its thrusters idle at their
    band, so a 95 % interval misses now and then: over 6 seeds × 2 axes at most 2 misses
    of the truth and of the prediction each (measured − predicted against both their
    σ: the hold's own ± can be the wider), none beyond 3σ."""
    payload, options = "0.4@W-aft-stbd", "disturb=real,truth=perturbed"
    seeds = range(6)
    agree = 0
    z_truth, z_predicted = [], []
    for seed in seeds:
        trim = sim_trim(bluerov, payload, seed, options)
        proposal = trim.result.proposal
        assert isinstance(proposal, Proposal), trim.result.reason
        v = verify_on_sim(trim, payload, seed, options, proposal.slots)
        truth = np.array(trim.trim_after_proposal_deg())
        measured = np.array([v.roll_deg, v.pitch_deg])
        sigma = np.array([v.roll_std_deg, v.pitch_std_deg])
        predicted = np.array([proposal.trim.roll_deg, proposal.trim.pitch_deg])
        z_truth += list(np.abs(measured - truth) / sigma)
        z_predicted += list(np.abs(measured - predicted)
                            / np.hypot(sigma, np.array(proposal.trim_std_deg)))
        agree += v.as_predicted
    for z in (np.array(z_truth), np.array(z_predicted)):
        assert np.sum(z > Z95) <= 2 and np.all(z < 3.0), z
    assert agree >= len(seeds) - 1


@pytest.mark.slow
def test_verify_hold_tells_a_wrongly_installed_ballast(sabertooth: Profile) -> None:
    """Sabertooth, 10 kg at AftSB: the proposal installed as proposed is level and as
    predicted; the same pieces mirrored port for starboard are neither, and the message
    names the roll moment."""
    payload, seed = "10@AftSB", 0
    trim = sim_trim(sabertooth, payload, seed)
    proposal = trim.result.proposal
    assert isinstance(proposal, Proposal)
    right = verify_on_sim(trim, payload, seed, "", proposal.slots)
    assert right.as_predicted and right.level, right.message
    mirrored = tuple(replace(ld, position_m=(ld.position_m[0], -ld.position_m[1],
                                             ld.position_m[2])) for ld in proposal.slots)
    wrong = verify_on_sim(trim, payload, seed, "", proposal.slots, on_vehicle=mirrored)
    assert not wrong.as_predicted and not wrong.level, wrong.message
    assert "NOT as predicted" in wrong.message and "W·y_g − B·y_b off by" in wrong.message
    # level but undecided (its 95 % wider than the tolerance): the operator is told what to
    # do; decided, or not level (a correction follows), nothing more
    assert right.undecided == (Z95 * max(right.roll_std_deg, right.pitch_std_deg) > 0.25)
    advice = undecided_advice(right)
    assert (advice is not None) == right.undecided
    assert undecided_advice(replace(right, roll_std_deg=0.1, pitch_std_deg=0.1)) is None
    narrow = replace(wrong, roll_std_deg=0.1, pitch_std_deg=0.1)
    assert undecided_advice(wrong) is None and not narrow.undecided


def test_run_verify_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                        sabertooth: Profile) -> None:
    """``trimd run --verify TRIM.json`` reads the trim's estimate and proposal, holds level
    once and prints one verification line; a file without a proposal is refused."""
    trim = sim_trim(sabertooth, "10@AftSB", 0)
    proposal = trim.result.proposal
    assert isinstance(proposal, Proposal) and trim.result.estimate is not None
    report = tmp_path / "trim.json"
    report.write_text(json.dumps({"type": "result",
                                  "estimate": estimate_to_dict(trim.result.estimate),
                                  "proposal": proposal_to_dict(proposal)}))
    link = f"sim:payload=10@AftSB+{carried(proposal.slots, sabertooth.gravity_m_s2)}"
    code = main(["run", "--link", link, "--profile", "sabertooth-dh2", "--headless", "--yes",
                 "--json", "--no-record", "--verify", str(report)])
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert code == 0
    v = [x for x in lines if x["type"] == "verification"]
    assert len(v) == 1 and v[0]["as_predicted"] and v[0]["level"], v
    commands = [x["command"] for x in lines if x["type"] == "command"]
    assert len(commands) == 2  # one level hold, then the release
    no_proposal = tmp_path / "estimate.json"
    no_proposal.write_text(json.dumps(estimate_to_dict(trim.result.estimate)))
    assert main(["run", "--link", link, "--profile", "sabertooth-dh2", "--headless", "--yes",
                 "--verify", str(no_proposal)]) == 2
    assert "no ballast proposal in it" in capsys.readouterr().err


def test_run_verify_from_the_history(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                     sabertooth: Profile) -> None:
    """``trimd run`` stores its trim; ``trimd run --verify`` (no file) verifies the last one
    and stores the outcome, which ``trimd history --json`` lists."""
    db = str(tmp_path / "trimd.db")
    common = ["--profile", "sabertooth-dh2", "--headless", "--yes", "--json", "--no-record",
              "--db", db]
    assert main(["run", "--link", "sim:payload=10@AftSB", *common]) == 0
    result = [json.loads(x) for x in capsys.readouterr().out.splitlines()][-1]
    slots = tuple(SlotLoad(s["name"], tuple(s["position_m"]), 0, 0, 0, 0, s["net_down_N"])
                  for s in result["proposal"]["slots"])
    link = f"sim:payload=10@AftSB+{carried(slots, sabertooth.gravity_m_s2)}"
    assert main(["run", "--link", link, "--verify", *common]) == 0
    out, err = capsys.readouterr()
    *_, v, correction = [json.loads(x) for x in out.splitlines()]
    assert v["type"] == "verification" and v["as_predicted"], v
    assert correction["type"] == "correction" and correction["needed"] is (not v["level"])
    # level, but its 95 % interval wider than the tolerance: what to do is said (stderr,
    # beside the JSON); this hold's is (± 0.8° in pitch against 0.25°)
    known = FLOAT_Z95 * max(v["trim_std_deg"])
    assert v["level"] and known > sabertooth.level_tol_deg, v
    assert (f"level, but undecided: the passive roll and pitch are known to ±{known:.2f}° "
            "at 95 %, wider than the level tolerance ±0.25°") in err, err
    assert "trimd float --correct" in err and "trimd calibrate --band" in err
    assert main(["history", "--db", db, "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    vehicle = listed["vehicles"][0]
    assert len(vehicle["trims"]) == 1 and len(vehicle["verifications"]) == 1, vehicle


def test_run_verify_refuses_what_it_cannot_check(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """Bad input is a clear error (exit 2) before anything is commanded: ``--verify`` with
    no trim in the history, and a trim whose proposal uses slots the profile lacks."""
    common = ["--link", "sim", "--profile", "bluerov2-heavy", "--headless", "--yes",
              "--no-record", "--db", str(tmp_path / "empty.db")]
    assert main(["run", *common, "--verify"]) == 2
    assert "no trim with a proposal for vehicle bluerov2-heavy" in capsys.readouterr().err
    heavy = load_profile("bluerov2-heavy")
    m = mass_properties(heavy)
    estimate = estimate_to_dict(estimate_static(equilibrium_holds(heavy, m.W, m.r_g), heavy))
    other = tmp_path / "sabertooth-trim.json"
    other.write_text(json.dumps({"type": "result", "estimate": estimate, "proposal": {"slots": [
        {"name": "AftSB", "position_m": [-1.0, 0.6, 0.0], "weight_kg": 1.0, "float_kg": 0.0,
         "mass_kg": 1.0, "net_down_N": 8.9, "pieces": {"lead-1kg": 1}}]}}))
    assert main(["run", *common, "--verify", str(other)]) == 2
    assert "uses slots ['AftSB'] that profile 'bluerov2-heavy' does not have" in (
        capsys.readouterr().err)
