"""A simulated vehicle whose truth differs from its profile (``truth=perturbed``).

The physics flies the perturbed vehicle (buoyancy, centre of buoyancy, thrust curves off by
the stated amounts, directions from the seed); trimd and the simulated autopilot read the
nominal profile; the true net quantities q and the passive trim after ballasting are
available to tests.
"""

from __future__ import annotations

import asyncio
import dataclasses

import numpy as np
import pytest

from tests.helpers import passive_attitude_deg, payload_truth
from trimd.app.connect import open_link
from trimd.core.model import band_edge_thrust, restoring_forces, thrusts_from_pwm
from trimd.core.profile import Profile
from trimd.drivers.sim.config import TRUTH_PERTURBED, SimConfig, parse_sim_options, with_presets
from trimd.drivers.sim.thrusters import ThrusterBank
from trimd.drivers.sim.truth import implied_mass, passive_trim_deg
from trimd.drivers.sim.vehicle import SimVehicle


def perturbed(seed: int, payload: str = "", **fields: object) -> SimConfig:
    return dataclasses.replace(
        with_presets(SimConfig(seed=seed, payload=payload), truth="perturbed"), **fields)


@pytest.mark.parametrize("name", ["bluerov", "sabertooth"])
def test_truth_differs_from_the_profile_by_the_stated_amounts(
        name: str, request: pytest.FixtureRequest) -> None:
    profile: Profile = request.getfixturevalue(name)
    signs, directions = set(), []
    for seed in range(12):
        v = SimVehicle(profile, perturbed(seed, esc_band_us=0.0))   # bands: the test below
        true = v.true_profile
        assert v.profile is profile                      # what trimd and the autopilot read
        assert abs(true.buoyancy_N / profile.buoyancy_N - 1) == pytest.approx(0.01)
        d_rb = np.subtract(true.r_b_m, profile.r_b_m)
        assert 1000 * np.linalg.norm(d_rb) == pytest.approx(5.0)
        signs.add(np.sign(true.buoyancy_N - profile.buoyancy_N))
        directions.append(d_rb / np.linalg.norm(d_rb))
        # thrust of every thruster, both directions, is 5 % off the profile's curve; the
        # deadband (zero thrust) is where it was
        nominal = ThrusterBank(profile, v.voltage_V, 0.0)
        for pwm in (1300, 1490, 1700, 1900):
            true_f = np.array(v.thrusters.thrust([pwm] * len(v.pwm_us)))
            nominal_f = np.array(nominal.thrust([pwm] * len(v.pwm_us)))
            if 1450 < pwm < 1550:
                assert np.all(true_f == nominal_f)
            else:
                assert np.allclose(np.abs(true_f / nominal_f - 1), 0.05), (pwm, true_f)
    assert signs == {-1.0, 1.0}
    assert np.linalg.norm(np.mean(directions, axis=0)) < 0.6      # not one direction


def test_thrust_err_max_draws_each_error_between_the_bounds(bluerov: Profile) -> None:
    """``thrust_err_max=0.1`` on ``truth=perturbed``: every thruster's error, forward and
    reverse, lies in [5 %, 10 %] and they differ; its sign, the buoyancy, the centre of
    buoyancy and the ESC bands are those of the same seed without it (a stream of its own)."""
    sizes = []
    for seed in range(6):
        plain, wide = (SimVehicle(bluerov, perturbed(seed, thrust_err_max=m)).offset
                       for m in (0.0, 0.1))
        assert (wide.buoyancy_factor, wide.r_b_offset_m, wide.band_offsets_us) == (
            plain.buoyancy_factor, plain.r_b_offset_m, plain.band_offsets_us)
        f_plain, f_wide = np.array(plain.thrust_factors) - 1, np.array(wide.thrust_factors) - 1
        assert np.all(np.sign(f_wide) == np.sign(f_plain))
        assert np.allclose(np.abs(f_plain), 0.05)
        sizes += list(np.abs(f_wide).ravel())
    assert min(sizes) >= 0.05 and max(sizes) <= 0.1 and np.std(sizes) > 0.01, sizes


def test_a_shape_error_changes_the_curve_along_it_and_nothing_else(bluerov: Profile) -> None:
    """``thrust_shape_err=0.05``: beside the gain error, each true curve is off by up to
    ±5 % near its band and ∓5 % at full thrust (no gain describes it); every other draw of the
    seed is that of the same seed without it (a stream of its own)."""
    v = bluerov.nominal_voltage_V
    signs = []
    for seed in range(3):
        plain, shaped = (SimVehicle(bluerov, perturbed(seed, thrust_shape_err=e))
                         for e in (0.0, 0.05))
        assert dataclasses.replace(shaped.offset, shape_errors=()) == plain.offset
        for i, (s_fwd, _) in enumerate(shaped.offset.shape_errors):
            # 1 µs past the positive edge of the true band, and at full thrust
            edge = plain.true_profile.thrusters[i].curve.tables[0].deadband_us[1] + 1
            pwm = np.full((2, len(bluerov.thrusters)), 1500.0)
            pwm[:, i] = edge, 1900.0
            ratio = (thrusts_from_pwm(shaped.true_profile, pwm, v)[:, i]
                     / thrusts_from_pwm(plain.true_profile, pwm, v)[:, i])
            # the table's first point past the band is at ≈ 10 % of full thrust: most of s
            assert abs(s_fwd) == 0.05 and 0.7 <= (ratio[0] - 1) / s_fwd <= 1.0
            assert ratio[1] == pytest.approx(1 - s_fwd, abs=0.002)  # tables mixed by voltage
            signs.append(s_fwd)
    assert len(set(signs)) == 2


@pytest.mark.parametrize("name", ["bluerov", "sabertooth"])
def test_esc_bands_are_offset_and_an_output_inside_hunts_at_the_edge(
        name: str, request: pytest.FixtureRequest) -> None:
    """Each ESC's band edges lie up to esc_band_us (4 µs) off the profile's, the curve
    beyond moving with them; an output inside the true band reports the first PWM out of
    it while delivering thrust linear from 0 at neutral to that PWM's: read through the
    profile's curve, the reported PWM is off the delivered thrust by up to the edge
    thrust."""
    profile: Profile = request.getfixturevalue(name)
    v = SimVehicle(profile, perturbed(3))
    offsets = np.array(v.offset.band_offsets_us)
    assert offsets.shape == (len(profile.thrusters), 2)
    assert np.all(np.abs(offsets) <= 4.0) and np.std(offsets) > 1.0
    bank, n = ThrusterBank(v.true_profile, v.voltage_V, 0.0, hunt=True), len(profile.thrusters)
    neutral = round(profile.thrusters[0].curve.neutral_us)
    errors = []
    for p in range(neutral - 40, neutral + 41):
        tau = bank.step([p] * n, 0.01)
        assert len(tau) == 6
        delivered = np.array(bank.force_N)
        reported = np.array(bank.reported_us)
        read = thrusts_from_pwm(profile, reported, v.voltage_V)
        for i in range(n):
            true_f = bank.thrust_at(i, p)
            if true_f == 0.0 and p != neutral:     # inside the true band: hunting
                assert reported[i] != p and np.sign(reported[i] - neutral) == np.sign(
                    p - neutral)
                assert bank.thrust_at(i, int(reported[i])) != 0.0
                assert abs(delivered[i]) < abs(bank.thrust_at(i, int(reported[i])))
            else:
                assert reported[i] == p and delivered[i] == pytest.approx(true_f)
        errors.append(read - delivered)
    edge = np.abs(band_edge_thrust(profile, v.voltage_V)).max()
    worst = np.abs(np.array(errors)).max()
    assert 0.2 * edge < worst <= 1.5 * edge, (worst, edge)


def test_torque_wander_leaves_the_stated_attitude_wander(sabertooth: Profile) -> None:
    """Disturbance torques sized for 0.2° RMS of attitude wander through the attitude loop
    (correlation 5 s): the attitude wanders by about that (within 40 %), the thrusters
    fight the torque, so roll and pitch effort wander by nearly its whole size."""
    v = SimVehicle(sabertooth, SimConfig(payload="10@AftSB", noise=0.0, seed=2,
                                         torque_wander_deg=0.2, torque_wander_tau_s=5.0))
    v.run_for(20.0)
    att, tau, torque = [], [], []
    for _ in range(3000):
        v.run_for(0.1)
        att.append(v.truth.eta[3:5])
        tau.append(v.truth.tau[3:5])
        torque.append(v.disturbances.torque_Nm)
    rms = np.degrees(np.std(att, axis=0))
    assert np.all((rms > 0.12) & (rms < 0.28)), rms
    assert np.all(np.std(tau, axis=0) > 0.5 * np.std(torque, axis=0))


def test_true_net_quantities_and_reproducible_by_seed(bluerov: Profile) -> None:
    payload, m, r = "0.4@0.1,-0.05,0.1", 0.4, np.array([0.1, -0.05, 0.1])
    v = SimVehicle(bluerov, perturbed(7, payload))
    W, r_g = payload_truth(bluerov, m, r)
    B, r_b = bluerov.buoyancy_N * v.offset.buoyancy_factor, np.add(bluerov.r_b_m,
                                                                   v.offset.r_b_offset_m)
    q = v.truth.mass.net
    assert np.allclose(q, np.r_[W - B, W * r_g - B * r_b])
    nominal = SimVehicle(bluerov, SimConfig(payload=payload)).truth.mass.net
    assert abs(q[0] - nominal[0]) == pytest.approx(0.01 * bluerov.buoyancy_N)
    assert 4.0 < 1000 * np.linalg.norm(q[1:] - nominal[1:]) / B < 6.0   # ≈ 5 mm of r_b
    again = SimVehicle(bluerov, perturbed(7, payload))
    assert np.array_equal(again.truth.mass.net, q) and again.offset == v.offset
    assert not np.allclose(SimVehicle(bluerov, perturbed(8, payload)).truth.mass.net, q)
    # what an exact estimate reads through the nominal profile: the same q, another m_ext
    m_ext, r_g_seen = implied_mass(bluerov, q)
    assert abs(m_ext - m) == pytest.approx(0.01 * bluerov.buoyancy_N / bluerov.gravity_m_s2)
    W_seen = (bluerov.mass_kg + m_ext) * bluerov.gravity_m_s2
    assert np.allclose(W_seen * r_g_seen - bluerov.buoyancy_N * np.asarray(bluerov.r_b_m),
                       q[1:])
    # the noise and disturbances do not move the truth: one seed, one vehicle
    real = with_presets(perturbed(7, payload), disturb="real")
    assert np.array_equal(SimVehicle(bluerov, real).truth.mass.net, q)
    # truth_seed: the vehicle of seed 7 on a dive of another seed (a later trim, a
    # calibration), another vehicle only without it
    dive = SimVehicle(bluerov, perturbed(9, payload, truth_seed=7, thrust_err_max=0.1))
    assert np.array_equal(dive.truth.mass.net, q)
    assert dive.offset == SimVehicle(bluerov, perturbed(7, payload, thrust_err_max=0.1)).offset
    assert parse_sim_options("seed=9,truth_seed=7").truth_seed == 7


def test_url_options(bluerov: Profile) -> None:
    c = parse_sim_options("truth=perturbed,seed=3,cob_err_mm=2")
    assert (c.buoyancy_err, c.cob_err_mm, c.thrust_err, c.seed) == (0.01, 2.0, 0.05, 3)
    assert parse_sim_options("truth=profile", base=c) == SimConfig(seed=3)
    assert TRUTH_PERTURBED == {"buoyancy_err": 0.01, "cob_err_mm": 5.0, "thrust_err": 0.05,
                               "esc_band_us": 4.0, "esc_hunt": True}

    async def truth_line() -> str:
        link = await open_link("sim:payload=0.4@W-aft-ctr,truth=perturbed,seed=3", bluerov)
        return link.truth()  # type: ignore[attr-defined, no-any-return]

    line = asyncio.run(truth_line())
    assert "off its profile (B ×" in line and "an exact estimate reads m_ext" in line
    nominal = SimVehicle(bluerov, SimConfig(payload="0.4@W-aft-ctr"))
    assert nominal.true_profile is bluerov and "off its profile" not in nominal.describe_truth()


def test_the_vehicle_floats_at_the_true_passive_trim(bluerov: Profile) -> None:
    """Disarmed, the perturbed vehicle floats where its TRUE q says (not where the
    profile's does), and :meth:`SimVehicle.ballasted` predicts it after ballasting."""
    config = perturbed(5, "0.4@W-aft-ctr")
    v = SimVehicle(bluerov, config)
    nominal = passive_trim_deg(SimVehicle(bluerov, SimConfig(payload=config.payload))
                               .truth.mass.net)
    predicted = passive_trim_deg(v.truth.mass.net)
    assert np.max(np.abs(np.subtract(predicted, nominal))) > 2.0     # 5 mm of r_b shows
    assert np.allclose(passive_attitude_deg(bluerov, config.payload, config), predicted,
                       atol=0.05)
    extra = "-0.2@W-aft-ctr+0.1@W-front-stbd"
    after = passive_trim_deg(v.ballasted(extra).net)
    # (sinking at a tilt, the Munk moment of the added masses moves it by < 0.1°)
    assert np.allclose(passive_attitude_deg(bluerov, config.payload + "+" + extra, config),
                       after, atol=0.15)


def test_a_hold_balances_the_true_vehicle_with_the_true_thrust(bluerov: Profile) -> None:
    """Station-keeping hold, noise off: the thrust the vehicle really makes balances the
    TRUE g(η); τ computed from the reported PWM through the profile's curves is off by the
    thrust error (what trimd would see: the reported PWM, hunting at a band edge where the
    ESC's band is offset)."""
    from trimd.core.model import tau_from_pwm

    config = with_presets(SimConfig(seed=1, payload="0.4@W-aft-ctr", noise=0.0, station=True),
                          truth="perturbed")
    v = SimVehicle(bluerov, config)
    v.hold_attitude(np.radians(10), np.radians(10), 0.0)
    v.run_for(90.0)
    true_tau, profile_tau = [], []
    for _ in range(100):
        v.run_for(0.1)
        true_tau.append(v.truth.tau)
        profile_tau.append(tau_from_pwm(bluerov, v.thrusters.reported_us, v.voltage_V))
    t = v.truth
    g = restoring_forces(t.eta[3], t.eta[4], t.mass.W, t.mass.B, t.mass.r_g, t.mass.r_b)
    assert np.allclose(np.mean(true_tau, axis=0), g, atol=0.02)
    seen = np.mean(profile_tau, axis=0)
    assert np.max(np.abs(seen - g)) > 0.02                     # the thrust error shows
    # about 5 % of the thrust, plus the ESC offsets' share: up to an edge thrust a thruster
    edge = float(np.abs(band_edge_thrust(bluerov, v.voltage_V)).max())
    assert np.max(np.abs(seen - g)) < 0.1 * np.max(np.abs(g)) + 2 * edge
