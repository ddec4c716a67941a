"""Proposals that start from the ballast installed: they may remove or move pieces.

Physics is checked independently of the code under test: the vehicle with its payload
and the FINAL configuration (what is installed after the proposal, piece by piece) are
summed as point bodies and the passive attitude found by a root of Fossen's moment rows
(tests/ballast/test_ballast.py); end to end, the simulated vehicle carries the installed
pieces and the proposal's changes (tests/helpers.py).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import pytest

from tests.ballast.test_ballast import Payload, estimate_for, passive_attitude, true_bodies
from tests.helpers import assert_proposal_levels, sim_trim
from trimd.app.report import format_proposal
from trimd.ballast.changes import Change
from trimd.ballast.propose import Proposal, proposal_to_dict, propose_ballast
from trimd.core.errors import ProfileError
from trimd.core.profile import InstalledPiece, Profile

LEAD, FOAM = "lead-200g", "foam-4x4x6.4cm"


def piece_bodies(profile: Profile, pieces: Sequence[InstalledPiece]) -> list[Payload]:
    """Installed pieces as point payloads at their slots."""
    rho = profile.water_density_kg_m3
    out = []
    for x in pieces:
        p = profile.piece(x.piece)
        out.append(Payload(x.count * p.mass_kg, x.count * rho * p.volume_m3,
                           profile.slot(x.slot).position_m))
    return out


def final_attitude(profile: Profile, payload: Sequence[Payload], proposal: Proposal
                   ) -> tuple[float, float, float]:
    """Roll, pitch [deg] and B − W [N] of the vehicle with the proposal's final ballast."""
    bodies = true_bodies(profile, [*payload, *piece_bodies(profile, proposal.installed_after)])
    return passive_attitude(profile, bodies)


def scenario(profile: Profile, installed: list[InstalledPiece], payload: list[Payload]
             ) -> tuple[Proposal, Proposal]:
    """The proposal from what is installed, and the adding-only one, for a vehicle that
    carries ``payload`` and ``installed`` (both in its measured estimate)."""
    est = estimate_for(profile, [*payload, *piece_bodies(profile, installed)])
    return (propose_ballast(est, profile, installed=installed),
            propose_ballast(est, profile, installed=()))


def check_final(profile: Profile, payload: Sequence[Payload], p: Proposal) -> None:
    roll, pitch, net = final_attitude(profile, payload, p)
    assert max(abs(roll), abs(pitch)) <= profile.level_tol_deg + 1e-9, (roll, pitch, p.message)
    assert (p.trim.roll_deg, p.trim.pitch_deg) == pytest.approx((roll, pitch), abs=1e-7)
    assert p.trim.net_buoyancy_N == pytest.approx(net, abs=1e-6)


def test_ballast_no_longer_needed_is_removed(bluerov: Profile) -> None:
    """Lead left aft on the nominal vehicle: taking it out levels it, 2 handlings, not the 4
    that adding counter-weight takes."""
    installed = [InstalledPiece("W-aft-ctr", LEAD, 2)]
    p, add_only = scenario(bluerov, installed, [])
    assert p.feasible and add_only.feasible
    assert p.changes == (Change("remove", LEAD, 2, "W-aft-ctr", None),)
    assert p.installed_after == () and p.added_mass_kg == pytest.approx(-0.4)
    check_final(bluerov, [], p)
    assert p.pieces_handled == 2 < add_only.pieces_handled
    assert "remove 2 × lead-200g from W-aft-ctr" in format_proposal(p)


def test_lead_is_moved_rather_than_added(bluerov: Profile) -> None:
    """A float mounted at the nose of a vehicle trimmed with lead aft: the lead goes
    forward (a move counts once), fewer pieces handled than adding only."""
    installed = [InstalledPiece("W-aft-ctr", LEAD, 2)]
    payload = [Payload(0.0, 0.5, (0.15, 0.0, 0.0))]
    p, add_only = scenario(bluerov, installed, payload)
    assert p.feasible
    moves = [c for c in p.changes if c.action == "move"]
    assert moves and all(c.from_slot == "W-aft-ctr" and c.piece == LEAD for c in moves)
    assert sum(c.count for c in moves) == 2
    check_final(bluerov, payload, p)
    assert p.pieces_handled < add_only.pieces_handled
    text = format_proposal(p)
    assert all(f"move {c.count} × {LEAD} from W-aft-ctr to {c.to_slot}" in text for c in moves)
    d = proposal_to_dict(p)
    assert d["changes"][0]["action"] == "move" and d["pieces_handled"] == p.pieces_handled
    assert d["installed_before"] == [{"slot": "W-aft-ctr", "piece": LEAD, "count": 2}]
    assert sum(x["count"] for x in d["installed_after"] if x["piece"] == LEAD) >= 2


def _random_case(profile: Profile, rng: np.random.Generator
                 ) -> tuple[list[InstalledPiece], list[Payload]]:
    weights = [s.name for s in profile.slots if s.max_weight_kg > 0]
    floats = [s.name for s in profile.slots if s.max_float_kg > 0]
    installed = [InstalledPiece(str(s), LEAD, int(rng.integers(1, 4)))
                 for s in rng.choice(weights, int(rng.integers(1, 4)), replace=False)]
    installed += [InstalledPiece(str(s), FOAM, int(rng.integers(1, 5)))
                  for s in rng.choice(floats, int(rng.integers(0, 3)), replace=False)]
    payload = [Payload(float(rng.uniform(0.0, 0.4)), float(rng.uniform(0.0, 0.4)),
                       tuple(rng.uniform([-0.15, -0.12, -0.05], [0.15, 0.12, 0.1])))]
    return installed, payload


def _window_miss_pct(p: Proposal) -> float:
    assert p.window_pct is not None
    lo, hi = p.window_pct
    return max(lo - p.trim.net_buoyancy_pct, p.trim.net_buoyancy_pct - hi, 0.0)


def _level_excess_Nm(p: Proposal) -> float:
    m = p.trim.net_moment_Nm
    return max(abs(m[0]), abs(m[1])) - math.tan(math.radians(p.level_tol_deg)) * m[2]


def test_never_worse_than_adding_only(bluerov: Profile) -> None:
    """Adding only is one of the choices the proposal from the installed ballast has: it is
    never worse in the window, the level or the pieces handled (in that priority), and
    every feasible one levels the vehicle by independent physics."""
    rng = np.random.default_rng(15)
    fewer = 0
    for _ in range(12):
        installed, payload = _random_case(bluerov, rng)
        p, add_only = scenario(bluerov, installed, payload)
        assert _window_miss_pct(p) <= _window_miss_pct(add_only) + 1e-6
        if add_only.feasible:
            assert p.feasible and p.pieces_handled <= add_only.pieces_handled
            fewer += p.pieces_handled < add_only.pieces_handled
        elif _window_miss_pct(p) >= _window_miss_pct(add_only) - 1e-6:
            assert _level_excess_Nm(p) <= max(_level_excess_Nm(add_only), 0.0) + 0.02
        if p.feasible:
            check_final(bluerov, payload, p)
    assert fewer >= 6  # removing or moving usually saves handling


def test_nothing_to_remove_beyond_what_is_installed_and_the_limit_named(
        bluerov: Profile) -> None:
    """No spare pieces and a nose-heavy payload too heavy for the window: the proposal
    takes out at most what is installed, is not feasible, and names the window."""
    empty = dataclasses.replace(bluerov, inventory=tuple(
        dataclasses.replace(p, count=0) for p in bluerov.inventory))
    installed = [InstalledPiece("W-aft-ctr", LEAD, 3)]
    p, _ = scenario(empty, installed, [Payload(0.6, 0.0, (0.2, 0.0, 0.05))])
    assert not p.feasible and "net buoyancy ≥ 0.3 %" in p.binding
    assert all(c.action == "remove" for c in p.changes)
    assert sum(c.count for c in p.changes) <= 3
    assert "cannot meet" in p.message


def test_installed_ballast_with_an_unknown_name_is_a_profile_error(bluerov: Profile) -> None:
    est = estimate_for(bluerov, [])
    with pytest.raises(ProfileError, match="did you mean 'W-aft-ctr'"):
        propose_ballast(est, bluerov, installed=[InstalledPiece("W-aft-ctrr", LEAD, 1)])


def test_removing_installed_lead_levels_the_simulated_vehicle(bluerov: Profile) -> None:
    """End to end: the simulated BlueROV2 carries 2 lead pieces aft (the profile declares
    them installed) and a payload; the trim's proposal from the installed ballast, put on
    the simulated vehicle (removals as negative loads), floats it level."""
    installed = (InstalledPiece("W-aft-ctr", LEAD, 2),)
    profile = dataclasses.replace(bluerov, installed=installed)
    lead = bluerov.piece(LEAD)
    net_kg = 2 * (lead.mass_kg - bluerov.water_density_kg_m3 * lead.volume_m3)
    payload = f"{net_kg:.6f}@W-aft-ctr+0.15@0.1,-0.05,0.05"
    run = sim_trim(profile, payload, seed=4)
    proposal = run.result.proposal
    assert isinstance(proposal, Proposal) and proposal.feasible, run.result.reason
    assert proposal.installed == installed
    assert any(s.removed for s in proposal.slots), format_proposal(proposal)
    assert_proposal_levels(profile, payload, proposal)
