"""The simulator's dive scenario: a leak, a lost piece, a scripted pilot."""

from __future__ import annotations

import numpy as np
import pytest

from trimd.core.errors import LinkError
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.config import parse_sim_options
from trimd.drivers.sim.link import open_sim_link
from trimd.drivers.sim.scenario import DIVE, PILOT_SCRIPTS, TRANSITS_RAMP_S
from trimd.drivers.sim.vehicle import SimVehicle


def test_a_leak_adds_weight_at_its_rate_from_its_start() -> None:
    p = load_profile("bluerov2-heavy")
    v = SimVehicle(p, parse_sim_options("leak_N_min=3,leak_start_s=10,leak_at=W-aft-ctr"))
    q0 = v.truth.mass.net.copy()
    v.run_for(10.0)
    assert np.allclose(v.truth.mass.net, q0)
    v.run_for(60.0)
    dq = v.truth.mass.net - q0
    leaked = 3.0 * (v.t_s - 1 - 10) / 60   # applied each whole second: at most 1 s behind
    assert dq[0] == pytest.approx(leaked, abs=3.0 / 60)
    # the water sits at the slot: its moment is its weight times the slot's arm
    assert np.allclose(dq[1:], dq[0] * np.asarray(p.slot("W-aft-ctr").position_m), atol=1e-9)


def test_a_flooding_housing_fills_up_and_stops() -> None:
    """``leak_max_N``: the water stops coming in once that much is in."""
    v = SimVehicle(load_profile("bluerov2-heavy"),
                   parse_sim_options("leak_N_min=60,leak_start_s=5,leak_max_N=8"))
    q0 = v.truth.mass.net[0]
    v.run_for(10.0)
    assert 4.0 <= v.truth.mass.net[0] - q0 < 8.0      # 1 N/s for the seconds since 5 s
    v.run_for(10.0)
    assert v.truth.mass.net[0] - q0 == pytest.approx(8.0, abs=1e-9)


def test_a_dropped_piece_takes_its_in_water_weight_at_its_time() -> None:
    p = load_profile("bluerov2-heavy")
    v = SimVehicle(p, parse_sim_options("drop=lead-200g@W-front-stbd@5"))
    q0 = v.truth.mass.net.copy()
    v.run_for(6.0)
    piece = next(x for x in p.inventory if x.name == "lead-200g")
    w = (piece.mass_kg - p.water_density_kg_m3 * piece.volume_m3) * p.gravity_m_s2
    dq = v.truth.mass.net - q0
    assert dq[0] == pytest.approx(-w)
    assert np.allclose(dq[1:], -w * np.asarray(p.slot("W-front-stbd").position_m))


def test_the_scripted_pilot_moves_the_vehicle_as_sticks_do() -> None:
    """Its transit drives the vehicle forward, its descent moves the depth target down,
    and between them it holds still."""
    p = load_profile("bluerov2-heavy")
    v = SimVehicle(p, parse_sim_options("pilot=dive,noise=0"))
    hover, transit = DIVE[0][0], DIVE[1][0]
    v.run_for(hover - 1)
    assert abs(v.truth.nu[0]) < 0.01
    v.run_for(transit)
    assert v.truth.nu[0] > 0.2
    descend_at = sum(d for d, _ in DIVE[:5])
    v.run_for(descend_at - v.t_s + DIVE[5][0] + 20)
    assert v.truth.eta[2] > 5.0 + 0.8


def test_the_transits_pilot_cruises_turns_and_stops_at_one_attitude() -> None:
    """Its sticks move over the ramp (half-way at half the ramp, from neutral at the
    start); the vehicle cruises at ≈ 0.4 m/s, turns ≈ 55° at the transit's end and is
    at rest again before the stop ends, level within 2° once the ramps are over and
    within 4° throughout (ArduSub's attitude loop)."""
    p = load_profile("bluerov2-heavy")
    script = PILOT_SCRIPTS["transits"]
    assert script.sticks(TRANSITS_RAMP_S / 2) == pytest.approx((0.175, 0.0, 0.0, 0.0))
    v = SimVehicle(p, parse_sim_options("pilot=transits,attitude_bandwidth_rad_s=6,noise=0"))
    attitude, speeds = [], []
    while v.t_s < 60.0:
        v.run_for(0.1)
        attitude.append((v.t_s, *np.degrees(np.abs(v.truth.eta[3:5]))))
        speeds.append((v.t_s, v.truth.nu[0]))
    tilt = np.array(attitude)
    assert tilt[:, 1:].max() < 4.0
    settled = (tilt[:, 0] % 60 > TRANSITS_RAMP_S) & (tilt[:, 0] % 60 < 16.0) | (
        tilt[:, 0] > 30.0)
    assert tilt[settled, 1:].max() < 2.0
    t, u = np.array(speeds).T
    assert 0.3 < np.interp(15.0, t, u) < 0.5 and abs(u[-1]) < 0.02
    assert np.degrees(v.truth.eta[5]) == pytest.approx(55.0, abs=10.0)


@pytest.mark.parametrize(("options", "words"), [
    ("drop=lead@W-aft-ctr@5", "no piece 'lead'"),
    ("drop=lead-200g@nowhere@5", "no ballast slot"),
    ("drop=lead-200g@W-aft-ctr", "PIECE@SLOT@T_S"),
    ("pilot=cruise", "known scripts"),
    ("leak_N_min=-1", "adds weight"),
    ("leak_N_min=1,leak_max_N=-2", "adds weight"),
])
def test_bad_scenario_options_are_link_errors(options: str, words: str) -> None:
    with pytest.raises(LinkError, match=words):
        open_sim_link(options, load_profile("bluerov2-heavy"))
