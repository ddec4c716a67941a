"""Ballast proposal: the thesis example, infeasible and degenerate inputs, the CLI.

Every proposal is checked here by independent physics: the vehicle, the payload and
the proposed ballast are summed as point masses and buoyancies, and the passive
attitude is found by a numerical root of Fossen's moment rows (trimd.core.model), never by
the code under test.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import root

from tests.helpers import equilibrium_holds, payload_truth
from trimd.app.report import format_proposal
from trimd.ballast.line import line_split
from trimd.ballast.propose import METHODS, Proposal, proposal_to_dict, propose_ballast
from trimd.cli.main import main
from trimd.core.errors import DataError, ProfileError
from trimd.core.estimate import StaticEstimate, estimate_static
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.model import restoring_forces
from trimd.core.profile import BallastSlot, Profile

Vec3 = tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class Payload:
    """A point payload: dry mass [kg] and displaced water [kgf] at a position [m]."""

    mass_kg: float
    displaced_kgf: float
    position_m: Vec3


Body = tuple[float, float, Vec3]  # mass [kg], buoyancy [N], position [m]


def true_bodies(profile: Profile, payloads: Sequence[Payload]) -> list[Body]:
    """The nominal vehicle (mass at CG0, buoyancy at r_b) and the payloads."""
    g = profile.gravity_m_s2
    return [(profile.mass_kg, 0.0, (0.0, 0.0, 0.0)), (0.0, profile.buoyancy_N, profile.r_b_m),
            *((p.mass_kg, p.displaced_kgf * g, p.position_m) for p in payloads)]


def estimate_for(profile: Profile, payloads: Sequence[Payload],
                 q_std: Sequence[float] = (1.0, 0.01, 0.01, 0.01)) -> StaticEstimate:
    """What a perfect measurement reports: the true net q, centres from the profile's prior."""
    g = profile.gravity_m_s2
    bodies = true_bodies(profile, payloads)
    q = np.zeros(4)
    for m, b, r in bodies:
        q += (m * g - b) * np.r_[1.0, r]
    B, r_b = profile.buoyancy_N, np.array(profile.r_b_m)
    W = float(q[0]) + B
    return StaticEstimate(
        q=q, q_cov=np.diag(np.square(q_std)), weight_N=W, buoyancy_N=B, r_b_m=r_b,
        r_g_m=(q[1:] + B * r_b) / W, cov=np.eye(4), m_ext_kg=W / g - profile.mass_kg,
        gravity_m_s2=g, holds=(), dofs_used=(), residual_rms=np.zeros(6))


def ballast_bodies(profile: Profile, proposal: Proposal) -> list[Body]:
    """The proposed ballast from its pieces (real), or ideal kilograms when it has none."""
    g, rho = profile.gravity_m_s2, profile.water_density_kg_m3
    pieces = {p.name: p for p in profile.inventory}
    bodies: list[Body] = []
    for s in proposal.slots:
        if s.pieces:
            bodies += [(n * pieces[name].mass_kg, n * rho * g * pieces[name].volume_m3,
                        s.position_m) for name, n in s.pieces]
        else:
            bodies += [(s.weight_kg, s.float_kg * g, s.position_m)]
    return bodies


def passive_attitude(profile: Profile, bodies: Sequence[Body]) -> tuple[float, float, float]:
    """Passive roll, pitch [deg] and net buoyancy B − W [N] of the bodies together."""
    g = profile.gravity_m_s2
    m = np.array([b[0] for b in bodies])
    buoy = np.array([b[1] for b in bodies])
    r = np.array([b[2] for b in bodies], dtype=float)
    W, B = float(m.sum()) * g, float(buoy.sum())
    r_g, r_b = m @ r / m.sum(), buoy @ r / B
    sol = root(lambda a: restoring_forces(a[0], a[1], W, B, r_g, r_b)[3:5], [0.0, 0.0],
               tol=1e-13)
    assert np.max(np.abs(sol.fun)) < 1e-10 * (1.0 + W), sol.message  # at machine precision
    return float(np.degrees(sol.x[0])), float(np.degrees(sol.x[1])), B - W


def check_levels(profile: Profile, payloads: Sequence[Payload], proposal: Proposal,
                 tol_deg: float) -> float:
    """Assert the proposal's report matches independent physics and levels to tol_deg."""
    roll, pitch, net = passive_attitude(profile, true_bodies(profile, payloads)
                                        + ballast_bodies(profile, proposal))
    assert abs(roll) < tol_deg and abs(pitch) < tol_deg, (roll, pitch, proposal.message)
    assert proposal.trim.roll_deg == pytest.approx(roll, abs=1e-7)
    assert proposal.trim.pitch_deg == pytest.approx(pitch, abs=1e-7)
    assert proposal.trim.net_buoyancy_N == pytest.approx(net, abs=1e-6)
    return net


def loads(p: Proposal) -> dict[str, float]:
    return {s.name: s.weight_kg for s in p.slots}


THESIS_AFT_SB = Payload(10.0, 0.0, (-1.031, 0.6, 0.0))


@pytest.fixture(scope="module")
def thesis_vehicle(sabertooth: Profile) -> Profile:
    """The thesis's lp and line (eq. 3.4/3.5) bound weights below only; its own answer
    puts 11.6 kg in FrontP, beyond the 0–10 kg the shipped profile allows."""
    slots = tuple(dataclasses.replace(s, max_weight_kg=20.0) for s in sabertooth.slots)
    return dataclasses.replace(sabertooth, slots=slots)


@pytest.fixture(scope="module")
def thesis_estimate(sabertooth: Profile) -> StaticEstimate:
    """10 kg at AftSB, estimated by trimd from noise-free holds."""
    W, r_g = payload_truth(sabertooth, 10.0, np.array(THESIS_AFT_SB.position_m))
    return estimate_static(equilibrium_holds(sabertooth, W, r_g), sabertooth)


def test_line_split_thesis_geometry(thesis_estimate: StaticEstimate) -> None:
    front = np.array([[0.78, 0.6], [0.78, -0.6]])
    split = line_split(thesis_estimate.q[1:3], front, 9.81)
    assert split is not None
    assert split.point_m == pytest.approx((0.78, -0.4535), abs=5e-4)
    assert split.mass_kg == pytest.approx(13.22, abs=0.005)


@pytest.mark.parametrize("method", ["line", "lp"])
def test_thesis_example(thesis_vehicle: Profile, thesis_estimate: StaticEstimate,
                        method: str) -> None:
    """docs/method.md §4: FrontSB ≈ 1.61 kg, FrontP ≈ 11.61 kg; lp within 1 % of 1.613/11.641."""
    p = propose_ballast(thesis_estimate, thesis_vehicle, method)
    kg = loads(p)
    assert p.feasible and p.binding == ()
    assert kg["AftSB"] == kg["AftP"] == pytest.approx(0.0, abs=1e-9)
    assert kg["FrontSB"] == pytest.approx(1.61, abs=0.005)
    assert kg["FrontP"] == pytest.approx(11.61, abs=0.005)
    assert kg["FrontSB"] == pytest.approx(1.613, rel=0.01)
    assert kg["FrontP"] == pytest.approx(11.641, rel=0.01)
    check_levels(thesis_vehicle, [THESIS_AFT_SB], p, 1e-6)


def test_thesis_case_with_shipped_limits_is_best_achievable(sabertooth: Profile) -> None:
    """10 kg per slot cannot hold the 11.6 kg FrontP needs: FrontP full, the limit named."""
    est = estimate_for(sabertooth, [THESIS_AFT_SB])
    for method in ("lp", "line"):
        p = propose_ballast(est, sabertooth, method)
        assert not p.feasible and p.success
        assert p.binding == ("FrontP weight capacity (10 kg)",)
        assert "FrontP weight capacity" in p.message
        assert loads(p)["FrontP"] == pytest.approx(10.0)
        roll, pitch, _ = passive_attitude(sabertooth, true_bodies(sabertooth, [THESIS_AFT_SB])
                                          + ballast_bodies(sabertooth, p))
        assert abs(pitch) < 1e-4 and 1.0 < roll < 3.0  # pitch cancelled, roll left over
    assert "lever rule needs 11.609 kg at FrontP" in p.message


def test_general_and_milp_level_the_thesis_case(sabertooth: Profile) -> None:
    est = estimate_for(sabertooth, [THESIS_AFT_SB])
    general = propose_ballast(est, sabertooth, "general")
    assert general.feasible
    assert check_levels(sabertooth, [THESIS_AFT_SB], general, 0.01) >= -1e-9
    milp = propose_ballast(est, sabertooth, "milp")
    assert milp.feasible
    net = check_levels(sabertooth, [THESIS_AFT_SB], milp, milp.level_tol_deg + 1e-9)
    W = sum(b[0] for b in true_bodies(sabertooth, [THESIS_AFT_SB])
            + ballast_bodies(sabertooth, milp)) * sabertooth.gravity_m_s2
    lo, hi = sabertooth.net_buoyancy_pct
    assert lo <= 100 * net / W <= hi


def front_only(profile: Profile) -> Profile:
    return dataclasses.replace(profile, slots=tuple(s for s in profile.slots
                                                    if s.position_m[0] > 0))


def test_negative_counter_moment_with_weights_only(sabertooth: Profile) -> None:
    """A nose-heavy payload and front slots only: weights cannot help, floats can."""
    vehicle = front_only(sabertooth)
    payload = [Payload(5.0, 0.0, (0.5, 0.0, 0.0))]
    est = estimate_for(vehicle, payload)
    for method in ("lp", "line"):
        p = propose_ballast(est, vehicle, method)
        assert not p.feasible and p.added_mass_kg == pytest.approx(0.0, abs=1e-9)
        assert p.binding == ("weights only: the counter-moment needs weight where no slot is "
                             "(or a float)",)
        roll, pitch, _ = passive_attitude(vehicle, true_bodies(vehicle, payload))
        assert p.trim.roll_deg == pytest.approx(roll, abs=1e-9)
        assert p.trim.pitch_deg == pytest.approx(pitch, abs=1e-9) and pitch < -0.3
    assert "no segment between two weight slots" in p.message
    general = propose_ballast(est, vehicle, "general")
    assert general.feasible
    check_levels(vehicle, payload, general, 0.01)


def test_window_out_of_reach_names_the_float_limits(bluerov: Profile) -> None:
    """2 kg on a BlueROV2 needs more lift than all the foam on hand gives."""
    payload = [Payload(2.0, 0.0, (0.0, 0.0, 0.1))]
    p = propose_ballast(estimate_for(bluerov, payload), bluerov, "milp")
    assert not p.feasible and "net-buoyancy window" in p.message
    foam = next(i for i in bluerov.inventory if i.kind == "float")
    assert f"inventory: all {foam.count} × {foam.name} used" in p.binding
    assert "net buoyancy ≥ 0.3 %" in p.binding
    _, _, net = passive_attitude(bluerov, true_bodies(bluerov, payload)
                                 + ballast_bodies(bluerov, p))
    g = bluerov.gravity_m_s2
    lift = (foam.volume_m3 * bluerov.water_density_kg_m3 - foam.mass_kg) * g
    assert net == pytest.approx(foam.count * lift - 2.0 * g + bluerov.buoyancy_N
                                - bluerov.mass_kg * g, abs=1e-6)  # every float, no lead


def test_no_ballast_for_the_method(bluerov: Profile) -> None:
    empty = dataclasses.replace(bluerov, inventory=())
    payload = [Payload(0.1, 0.0, (0.1, 0.0, 0.0))]
    p = propose_ballast(estimate_for(empty, payload), empty, "milp")
    assert not p.feasible and p.binding == ("no slot takes the ballast this method uses",)
    assert p.slots and all(s.mass_kg == 0 for s in p.slots)


@pytest.mark.parametrize("method", METHODS)
def test_level_vehicle_gets_nothing(sabertooth: Profile, method: str) -> None:
    """The nominal Sabertooth is level and 0.5 % positive: nothing to add."""
    p = propose_ballast(estimate_for(sabertooth, []), sabertooth, method)
    assert p.feasible and p.added_mass_kg == pytest.approx(0.0, abs=1e-12) and p.binding == ()
    assert abs(p.trim.roll_deg) < 1e-9 and abs(p.trim.pitch_deg) < 1e-9


def test_unstable_vehicle_is_named(sabertooth: Profile) -> None:
    """Centre of buoyancy below the centre of gravity: levelled moments, yet it capsizes."""
    top_heavy = dataclasses.replace(sabertooth, r_b_m=(0.0, 0.0, 0.04))
    payload = [Payload(2.0, 0.0, (-0.5, 0.3, 0.0))]
    p = propose_ballast(estimate_for(top_heavy, payload), top_heavy, "lp")
    assert not p.feasible and not p.trim.stable
    assert len(p.binding) == 1
    assert p.binding[0].startswith("no static stability: W·z_g − B·z_b = -467 N·m ≤ 0")
    assert p.binding[0].endswith("the vehicle would capsize; passive trim undefined")
    assert np.isnan(p.trim.roll_deg) and np.isnan(p.trim.pitch_std_deg)
    assert p.trim.net_moment_Nm[:2] == pytest.approx([0.0, 0.0], abs=1e-6)  # balanced anyway


def test_trim_std_matches_numerical_propagation(bluerov: Profile) -> None:
    """The ± degrees equal √(J·Σ·Jᵀ) with J by finite differences of the independent solve."""
    payload = [Payload(0.3, 0.1, (0.05, -0.06, 0.05))]
    q_std = np.array([0.5, 0.004, 0.006, 0.02])
    p = propose_ballast(estimate_for(bluerov, payload, q_std), bluerov, "general")
    bodies = true_bodies(bluerov, payload) + ballast_bodies(bluerov, p)
    g = bluerov.gravity_m_s2
    J = np.zeros((2, 3))
    for k in range(3):
        h = 1e-4
        offset = np.zeros(3)
        offset[k] = h / g  # a 1 kg·m/g mass-moment pair: a pure moment h about axis k
        plus = [*bodies, (1.0, 0.0, tuple(offset)), (-1.0, 0.0, (0.0, 0.0, 0.0))]
        minus = [*bodies, (-1.0, 0.0, tuple(offset)), (1.0, 0.0, (0.0, 0.0, 0.0))]
        a, b = passive_attitude(bluerov, plus), passive_attitude(bluerov, minus)
        J[:, k] = (np.array(a[:2]) - np.array(b[:2])) / (2 * h)
    expected = np.sqrt(np.diag(J @ np.diag(q_std[1:] ** 2) @ J.T))
    np.testing.assert_allclose(p.trim_std_deg, expected, rtol=1e-4)
    assert p.trim.net_buoyancy_std_N == pytest.approx(0.5)


def test_input_errors(sabertooth: Profile, bluerov: Profile) -> None:
    est = estimate_for(sabertooth, [THESIS_AFT_SB])
    with pytest.raises(ProfileError, match="wrong profile"):
        propose_ballast(est, bluerov)
    with pytest.raises(ValueError, match="unknown ballast method"):
        propose_ballast(est, sabertooth, "simplex")
    bad = dataclasses.replace(est, q=np.array([np.nan, 0.0, 0.0, 0.0]))
    with pytest.raises(DataError, match="not finite"):
        propose_ballast(bad, sabertooth)


def write_estimate(tmp_path: Path, profile: Profile, payloads: Sequence[Payload]) -> Path:
    path = tmp_path / "est.json"
    path.write_text(json.dumps(estimate_to_dict(estimate_for(profile, payloads))))
    return path


@pytest.mark.parametrize("method", METHODS)
def test_cli_json(tmp_path: Path, sabertooth: Profile, capsys: pytest.CaptureFixture[str],
                  method: str) -> None:
    path = write_estimate(tmp_path, sabertooth, [Payload(3.0, 0.0, (-0.4, 0.2, 0.1))])
    assert main(["ballast", "--profile", "sabertooth-dh2", "--estimate", str(path),
                 "--method", method, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == method and out["feasible"] is True and out["binding"] == []
    assert [s["name"] for s in out["slots"]] == [s.name for s in sabertooth.slots]
    for s in out["slots"]:
        assert set(s) >= {"name", "position_m", "weight_kg", "float_kg", "pieces", "net_down_N"}
    assert len(out["predicted_trim_std_deg"]) == 2
    for key in ("added_mass_kg", "net_buoyancy_N", "predicted_roll_deg", "predicted_pitch_deg"):
        assert isinstance(out[key], float)
    assert abs(out["predicted_roll_deg"]) < 0.5 and abs(out["predicted_pitch_deg"]) < 0.5


def test_cli_table(tmp_path: Path, bluerov: Profile, capsys: pytest.CaptureFixture[str]) -> None:
    path = write_estimate(tmp_path, bluerov, [Payload(0.2, 0.0, (0.1, 0.1, 0.0))])
    assert main(["ballast", "--profile", "bluerov2-heavy", "--estimate", str(path)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("ballast by milp: feasible")
    assert "lead-200g" in text or "foam" in text
    assert "passive roll" in text and "net buoyancy" in text


@pytest.mark.parametrize(("content", "message"), [
    (None, "cannot read estimate"),
    ("{not json", "not valid JSON"),
    ("[1, 2]", "expected a JSON object"),
    ('{"weight_N": 1}', "missing 'buoyancy_N'"),
])
def test_cli_bad_estimate(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                          content: str | None, message: str) -> None:
    path = tmp_path / "est.json"
    if content is not None:
        path.write_text(content)
    assert main(["ballast", "--profile", "sabertooth-dh2", "--estimate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_cli_malformed_holds(tmp_path: Path, sabertooth: Profile,
                             capsys: pytest.CaptureFixture[str]) -> None:
    path = write_estimate(tmp_path, sabertooth, [])
    d = json.loads(path.read_text())
    d["holds"] = [{"label": "x"}]
    path.write_text(json.dumps(d))
    assert main(["ballast", "--profile", "sabertooth-dh2", "--estimate", str(path)]) == 2
    assert "malformed" in capsys.readouterr().err


def test_cli_wrong_profile(tmp_path: Path, sabertooth: Profile,
                           capsys: pytest.CaptureFixture[str]) -> None:
    path = write_estimate(tmp_path, sabertooth, [])
    assert main(["ballast", "--profile", "bluerov2-heavy", "--estimate", str(path)]) == 2
    assert "wrong profile?" in capsys.readouterr().err


def test_dict_and_table_of_every_slot_kind(bluerov: Profile) -> None:
    payload = [Payload(0.25, 0.0, (0.08, 0.1, 0.0))]
    p = propose_ballast(estimate_for(bluerov, payload), bluerov, "milp")
    d = json.loads(json.dumps(proposal_to_dict(p)))
    used = [s for s in d["slots"] if s["pieces"]]
    assert used and all(all(isinstance(n, int) for n in s["pieces"].values()) for s in used)
    g, rho = bluerov.gravity_m_s2, bluerov.water_density_kg_m3
    pieces = {i.name: i for i in bluerov.inventory}
    for s in used:
        net = sum(n * (pieces[k].mass_kg - rho * pieces[k].volume_m3) * g
                  for k, n in s["pieces"].items())
        assert s["net_down_N"] == pytest.approx(net)
    table = format_proposal(p)
    assert all(s["name"] in table for s in used)


def test_slot_z_changes_stability_not_level(bluerov: Profile) -> None:
    """A weight low on the frame raises m_z (W·z_g − B·z_b), leaving roll/pitch level."""
    payload = [Payload(0.2, 0.0, (0.1, 0.0, 0.0))]
    est = estimate_for(bluerov, payload)
    p = propose_ballast(est, bluerov, "lp")
    added = sum(s.weight_kg * s.position_m[2] for s in p.slots) * bluerov.gravity_m_s2
    assert p.trim.net_moment_Nm[2] == pytest.approx(est.q[3] + added)
    assert added > 0
    check_levels(bluerov, payload, p, 0.01)


def test_slot_with_room_for_no_piece_is_skipped(bluerov: Profile) -> None:
    tiny = BallastSlot("tiny", (0.1, 0.0, 0.1), max_weight_kg=0.1, max_float_kg=0.0)
    vehicle = dataclasses.replace(bluerov, slots=(*bluerov.slots, tiny))
    payload = [Payload(0.2, 0.0, (-0.05, 0.0, 0.0))]
    p = propose_ballast(estimate_for(vehicle, payload), vehicle, "milp")
    assert p.slots[-1].name == "tiny" and p.slots[-1].mass_kg == 0.0
