"""Static estimator: exact recovery, honest uncertainty, refusal when unidentifiable."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.helpers import equilibrium_holds, payload_truth
from trimd.core.curve_error import offset_band
from trimd.core.drift import munk_moment
from trimd.core.errors import EstimationError
from trimd.core.estimate import HoldSamples, estimate_static, measurable_dofs
from trimd.core.model import pwm_from_thrust, thrust_configuration, thrust_from_pwm
from trimd.core.profile import Profile


@pytest.mark.parametrize("m_ext", [1.0, 5.0, 10.0, 15.0, 20.0])
@pytest.mark.parametrize("slot", ["AftSB", "AftP", "FrontSB", "FrontP"])
def test_thesis_cases_noise_free(sabertooth: Profile, m_ext: float, slot: str) -> None:
    W, r_g = payload_truth(sabertooth, m_ext, sabertooth.slot(slot).position_m)
    est = estimate_static(equilibrium_holds(sabertooth, W, r_g), sabertooth)
    assert abs(est.m_ext_kg - m_ext) < 1e-3
    np.testing.assert_allclose(est.r_g_m, r_g, atol=1e-6, rtol=0)


def test_thesis_example_numbers(sabertooth: Profile) -> None:
    """10 kg at AftSB: x_g ≈ -8.6 mm, y_g ≈ +5.0 mm, z_g = 0 (docs/method.md §3)."""
    W, r_g = payload_truth(sabertooth, 10.0, sabertooth.slot("AftSB").position_m)
    est = estimate_static(equilibrium_holds(sabertooth, W, r_g), sabertooth)
    np.testing.assert_allclose(est.r_g_m * 1e3, [-8.635, 5.025, 0.0], atol=1e-3)


@settings(max_examples=60, deadline=None)
@given(m_ext=st.floats(0.5, 40.0),
       r=st.tuples(st.floats(-1.2, 1.2), st.floats(-0.7, 0.7), st.floats(-0.4, 0.4)))
def test_random_payloads_with_vertical_offset(sabertooth: Profile, m_ext: float,
                                              r: tuple[float, float, float]) -> None:
    W, r_g = payload_truth(sabertooth, m_ext, np.array(r))
    est = estimate_static(equilibrium_holds(sabertooth, W, r_g, n=20), sabertooth)
    assert abs(est.m_ext_kg - m_ext) < 1e-3
    np.testing.assert_allclose(est.r_g_m, r_g, atol=1e-6, rtol=0)


def test_noisy_estimate_within_three_sigma(sabertooth: Profile) -> None:
    W, r_g = payload_truth(sabertooth, 10.0, np.array([-1.031, 0.6, 0.15]))
    holds = equilibrium_holds(sabertooth, W, r_g, n=2000, attitude_noise_deg=0.1,
                              thrust_noise=0.02, rng=np.random.default_rng(7))
    est = estimate_static(holds, sabertooth)
    assert abs(est.m_ext_kg - 10.0) < 3 * est.m_ext_std_kg
    assert np.all(np.abs(est.r_g_m - r_g) < 3 * est.r_g_std_m)
    assert est.r_g_std_m[2] < 1e-3  # z_g is actually determined, to better than a mm


@pytest.mark.parametrize(("noise", "n"), [
    # rows with different noise levels, thrusters at half the attitude rate
    ({"attitude_noise_deg": 0.05, "thrust_noise": np.array([0.01, 0.05, 0.02, 0.1, 0.01, 0.03]),
      "thruster_every": 2}, 300),
    # an attitude estimate wandering 0.1° with a 5 s correlation, thrusters at ½ rate
    ({"attitude_noise_deg": 0.05, "thrust_noise": 0.02, "wander_deg": 0.1,
      "wander_tau_s": 5.0, "thruster_every": 2}, 3000),
])
def test_intervals_cover_the_net_quantities_under_correlated_noise(
        sabertooth: Profile, noise: dict[str, object], n: int) -> None:
    """Over 200 seeds the 95 % intervals of W − B and the three net moments cover the
    truth 90–99 % of the time, and error/σ has an RMS of 0.8–1.2. (The estimator with
    one pooled variance per row group and a lag-1 correction covered 86–100 % (RMS
    0.54–1.33) in the first case and 60–70 % (RMS ≈ 2) in the second.) The data have no
    slow error of the attitude reference beyond the wander drawn, so the profile states
    none (``attitude_error_deg`` 0; that term has its own test below)."""
    sabertooth = dataclasses.replace(sabertooth, attitude_error_deg=0.0)
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    truth = np.r_[W - sabertooth.buoyancy_N, W * r_g - sabertooth.buoyancy_N * np.asarray(
        sabertooth.r_b_m)]
    z = np.array([(est.q - truth) / np.sqrt(np.diag(est.q_cov)) for est in (
        estimate_static(equilibrium_holds(sabertooth, W, r_g, n=n, **noise,  # type: ignore[arg-type]
                                          rng=np.random.default_rng(seed)), sabertooth)
        for seed in range(200))])
    coverage = np.mean(np.abs(z) <= 1.96, axis=0)
    assert np.all((coverage >= 0.90) & (coverage <= 0.99)), coverage
    assert np.all(np.abs(np.sqrt(np.mean(z**2, axis=0)) - 1) <= 0.2), np.sqrt(np.mean(z**2, axis=0))


@pytest.mark.slow
def test_intervals_cover_the_net_quantities_when_the_wander_is_slower_than_the_hold(
        sabertooth: Profile) -> None:
    """Wander of 0.2° with a 20 s correlation over 3 min holds: each hold is worth 1–10
    independent samples, and the Student-t widening of those below seven
    (:func:`trimd.core.longrun.small_sample_factor`) keeps the 95 % intervals covering
    90–99 % over 200 seeds (88.5–96 % without it, 93–98.5 % with it). error/σ is then
    heavy-tailed, so its RMS is checked from above only."""
    sabertooth = dataclasses.replace(sabertooth, attitude_error_deg=0.0)
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    truth = np.r_[W - sabertooth.buoyancy_N, W * r_g - sabertooth.buoyancy_N * np.asarray(
        sabertooth.r_b_m)]
    ests = [estimate_static(equilibrium_holds(
        sabertooth, W, r_g, n=1800, attitude_noise_deg=0.05, thrust_noise=0.02, wander_deg=0.2,
        wander_tau_s=20.0, thruster_every=2, rng=np.random.default_rng(seed)), sabertooth)
        for seed in range(200)]
    assert sum(not h.resolved for e in ests for h in e.holds) > 100
    z = np.array([(e.q - truth) / np.sqrt(np.diag(e.q_cov)) for e in ests])
    coverage = np.mean(np.abs(z) <= 1.96, axis=0)
    assert np.all((coverage >= 0.90) & (coverage <= 0.99)), coverage
    assert np.all(np.sqrt(np.mean(z**2, axis=0)) <= 1.2), np.sqrt(np.mean(z**2, axis=0))


@pytest.mark.parametrize("profile_name", ["sabertooth", "bluerov"])
def test_intervals_cover_a_slow_error_of_the_attitude_reference(
        profile_name: str, request: pytest.FixtureRequest) -> None:
    """An AHRS whose roll and pitch are off by a constant per hold (drawn with the
    profile's ``attitude_error_deg``, 0.1°: it wanders over tens of seconds, longer than a
    hold): no length of collecting averages it out, so the ± must carry it. Over 200 seeds
    the 95 % intervals of W − B and the net moments cover 90–99 % (without the term, with
    thruster noise this small: W − B 86 %, the net moments 3–4 %)."""
    # the synthetic holds do not drift: no Munk moment to take out
    profile = dataclasses.replace(request.getfixturevalue(profile_name), holds_station=True)
    payload = {"sabertooth": (10.0, "AftSB"), "bluerov": (0.4, "W-aft-stbd")}[profile_name]
    W, r_g = payload_truth(profile, payload[0], np.array(profile.slot(payload[1]).position_m))
    truth = np.r_[W - profile.buoyancy_N, W * r_g - profile.buoyancy_N * np.asarray(
        profile.r_b_m)]
    sigma = np.radians(profile.attitude_error_deg)
    z = []
    for seed in range(200):
        rng = np.random.default_rng(seed)
        holds = equilibrium_holds(profile, W, r_g, n=300, attitude_noise_deg=0.02,
                                  thrust_noise=0.002, rng=rng)
        holds = [dataclasses.replace(h, phi=h.phi + sigma * rng.standard_normal(),
                                     theta=h.theta + sigma * rng.standard_normal())
                 for h in holds]
        est = estimate_static(holds, profile)
        z.append((est.q - truth) / np.sqrt(np.diag(est.q_cov)))
    coverage = np.mean(np.abs(z) <= 1.96, axis=0)
    assert np.all((coverage >= 0.90) & (coverage <= 0.99)), coverage


def read_through_wrong_curves(holds: Sequence[HoldSamples], profile: Profile,
                              gain: np.ndarray) -> list[HoldSamples]:
    """``holds`` (true τ) as trimd reads them when each thruster's true thrust is
    (1 + gain[i, 0]) times its curve forward and (1 + gain[i, 1]) in reverse: the thrust
    the curve gives for the commanded PWM, and the τ it makes."""
    T = thrust_configuration(profile.thrusters)
    out = []
    for h in holds:
        true = h.tau @ np.linalg.pinv(T).T
        read = true / (1 + np.where(true > 0, gain[:, 0], gain[:, 1]))
        out.append(HoldSamples(h.t_s, h.phi, h.theta, read @ T.T, h.label, read))
    return out


def with_thrust_uncertainty(profile: Profile, pct: float, margin_us: float | None = None
                            ) -> Profile:
    """``profile`` with its curves' ``uncertainty_pct`` set to ``pct`` and their dead-band
    margin to ``margin_us`` (default: unchanged, or 0 for ``pct`` 0: an exact map)."""
    margin = (0.0 if pct == 0 else None) if margin_us is None else margin_us
    return dataclasses.replace(profile, thrusters=tuple(
        dataclasses.replace(t, curve=dataclasses.replace(
            t.curve, uncertainty_pct=pct,
            deadband_margin_us=t.curve.deadband_margin_us if margin is None else margin))
        for t in profile.thrusters))


def read_through_offset_bands(holds: Sequence[HoldSamples], profile: Profile,
                              offset_us: np.ndarray) -> list[HoldSamples]:
    """``holds`` (true τ) as trimd reads them when each thruster's ESC has its dead band
    (and the curve beyond it) offset by ``offset_us[i]`` = (low side, high side) [µs]: the
    PWM that true ESC needs for the true thrust, read through the profile's curve."""
    T = thrust_configuration(profile.thrusters)
    v = profile.nominal_voltage_V
    out = []
    for h in holds:
        true = h.tau @ np.linalg.pinv(T).T
        read = np.column_stack([
            thrust_from_pwm(t.curve, pwm_from_thrust(offset_band(t.curve, *d), true[:, i], v),
                            v)
            for i, (t, d) in enumerate(zip(profile.thrusters, offset_us, strict=True))])
        out.append(HoldSamples(h.t_s, h.phi, h.theta, read @ T.T, h.label, read))
    return out


@pytest.mark.parametrize("error", ["gain", "band"])
@pytest.mark.parametrize(("name", "m_ext", "slot", "thrust_noise"), [
    ("bluerov", 0.4, "W-aft-ctr", 0.05), ("sabertooth", 10.0, "AftSB", 0.01)])
def test_intervals_cover_thrust_map_errors(request: pytest.FixtureRequest, name: str,
                                           m_ext: float, slot: str, thrust_noise: float,
                                           error: str) -> None:
    """``gain``: each thruster's true thrust is off its curve by a gain drawn with the
    profile's uncertainty_pct (5 %) as standard deviation, per direction. ``band``: each
    thruster's ESC has its dead band, and the curve beyond it, offset by up to the
    profile's deadband_margin_us (uniform, per thruster and side). Over 200 seeds the 95 %
    intervals of W − B and the net moments cover 90–99 % with that error in the ±, RMS
    error/σ 0.8–1.2. Without it they cover below 50 % on some quantity: every hold shares
    the error, and only its noise would be in the ±."""
    # equilibrium holds balance g(η) exactly: a vehicle that holds station, no drift
    profile = dataclasses.replace(request.getfixturevalue(name), holds_station=True)
    W, r_g = payload_truth(profile, m_ext, np.array(profile.slot(slot).position_m))
    truth = np.r_[W - profile.buoyancy_N, W * r_g - profile.buoyancy_N * np.asarray(
        profile.r_b_m)]
    sigma = np.array([t.curve.uncertainty_pct / 100 for t in profile.thrusters])
    margin = np.array([t.curve.deadband_margin_us for t in profile.thrusters])
    assert np.all(sigma == 0.05) and np.all(margin == 5.0)
    aware = (with_thrust_uncertainty(profile, 5.0, 0.0) if error == "gain"
             else with_thrust_uncertainty(profile, 0.0, 5.0))
    blind = with_thrust_uncertainty(profile, 0.0)
    z: dict[bool, list[np.ndarray]] = {True: [], False: []}
    for seed in range(200):
        rng = np.random.default_rng(seed)
        draw = (sigma[:, None] * rng.standard_normal((len(sigma), 2)) if error == "gain"
                else margin[:, None] * rng.uniform(-1, 1, (len(margin), 2)))
        holds = equilibrium_holds(profile, W, r_g, n=300, attitude_noise_deg=0.05,
                                  thrust_noise=thrust_noise, rng=rng)
        holds = (read_through_wrong_curves(holds, profile, draw) if error == "gain"
                 else read_through_offset_bands(holds, profile, draw))
        for knows, p in ((True, aware), (False, blind)):
            est = estimate_static(holds, p)
            z[knows].append((est.q - truth) / np.sqrt(np.diag(est.q_cov)))
    coverage = {k: np.mean(np.abs(np.array(v)) <= 1.96, axis=0) for k, v in z.items()}
    rms = np.sqrt(np.mean(np.array(z[True]) ** 2, axis=0))
    assert np.all((coverage[True] >= 0.90) & (coverage[True] <= 0.99)), coverage
    assert np.all(np.abs(rms - 1) <= 0.2), rms
    blind_misses = coverage[False] < 0.5
    assert np.all(blind_misses) if error == "gain" else np.any(blind_misses), coverage


def test_quiet_rows_without_information_do_not_decide_w_minus_b(bluerov: Profile) -> None:
    """At level the X and Y rows know W − B only through the tiny mean tilt. Noise-free,
    they once got the largest weight, and the thrust curves' uncertainty of the
    horizontal thrusters (here pushing against each other) divided by that tilt made a
    ± of W − B of hundreds of newtons. Weighted by their whole variance, W − B comes from
    the Z row, with the σ of its thrust: 5 % of each vertical thruster's share."""
    W, r_g = payload_truth(bluerov, 0.4, np.array(bluerov.slot("W-aft-ctr").position_m))
    holds = equilibrium_holds(bluerov, W, r_g, n=300, thrust_noise=np.array(
        [0, 0, 0.02, 0, 0, 0]), tilts_deg=((0.01, 0.0), (20, 20)))
    T = thrust_configuration(bluerov.thrusters)
    opposed = np.r_[1.0, 1.0, 1.0, 1.0, 0, 0, 0, 0]  # no net force or moment (T·opposed = 0)
    holds = [dataclasses.replace(h, thrust=h.tau @ np.linalg.pinv(T).T + opposed)
             for h in holds]
    # the dead band's share is the subject of test_intervals_cover_thrust_map_errors
    est = estimate_static(holds, with_thrust_uncertainty(bluerov, 5.0, 0.0))
    f = holds[0].thrust
    assert f is not None
    z_share = 0.05 * np.hypot(T[2] * np.maximum(f, 0).mean(axis=0),
                              T[2] * np.minimum(f, 0).mean(axis=0))
    assert est.weight_std_N == pytest.approx(float(np.linalg.norm(z_share)), rel=0.05)


def test_the_munk_moment_of_the_drift_is_taken_out(bluerov: Profile) -> None:
    """A tilted hold without station keeping carries the Munk moment of its drift on top
    of g(η) (tests/core/test_drift.py checks it against the simulator): the estimate
    takes it out, and its ± covers what the model could be off by; a profile that holds
    station takes nothing out."""
    W, r_g = payload_truth(bluerov, 0.4, np.array(bluerov.slot("W-aft-ctr").position_m))
    truth = np.r_[W - bluerov.buoyancy_N, W * r_g - bluerov.buoyancy_N * np.asarray(
        bluerov.r_b_m)]
    holds = equilibrium_holds(bluerov, W, r_g, n=50)
    tilted = holds[1]
    munk = munk_moment(bluerov, float(tilted.phi[0]), float(tilted.theta[0]), truth[0])
    holds[1] = dataclasses.replace(tilted, tau=tilted.tau + np.r_[0, 0, 0, munk])
    est = estimate_static(holds, bluerov)
    np.testing.assert_allclose(est.q, truth, atol=1e-9)
    station = estimate_static(holds, dataclasses.replace(bluerov, holds_station=True))
    bias = station.q[3] - truth[3]
    assert bias < -0.2e-3 * W                       # ≈ −0.3 mm-equivalent
    # noise-free, the ± is the model's alone: half the moment it takes out
    assert np.sqrt(est.q_cov[3, 3]) == pytest.approx(0.5 * abs(bias), rel=0.1)


def test_thrust_of_the_wrong_shape_is_refused(bluerov: Profile) -> None:
    W, r_g = payload_truth(bluerov, 0.4, np.array(bluerov.slot("W-aft-ctr").position_m))
    holds = equilibrium_holds(bluerov, W, r_g, n=20)
    holds[0] = dataclasses.replace(holds[0], thrust=np.zeros((20, 3)))
    with pytest.raises(EstimationError, match=r"\(20, 8\) expected"):
        estimate_static(holds, bluerov)


@pytest.mark.slow
@pytest.mark.parametrize(("m_ext", "position", "n"), [
    (8.0, (0.5, -0.4, 0.2), 300),
    (1.0, (0.78, -0.6, 0.0), 3000),     # a thesis case, long holds: a bias would show
    (15.0, (-1.031, 0.6, 0.0), 10000),
])
def test_confidence_intervals_cover_the_truth(sabertooth: Profile, m_ext: float,
                                              position: tuple[float, float, float],
                                              n: int) -> None:
    """Over 200 seeds the 95 % intervals of m_ext, x_g, y_g, z_g cover 90–99 % of the time
    (white noise only: no slow error of the attitude reference, ``attitude_error_deg`` 0)."""
    sabertooth = dataclasses.replace(sabertooth, attitude_error_deg=0.0)
    W, r_g = payload_truth(sabertooth, m_ext, np.array(position))
    truth = np.r_[m_ext, r_g]
    hits = np.zeros(4)
    seeds = 200
    for seed in range(seeds):
        holds = equilibrium_holds(sabertooth, W, r_g, n=n, attitude_noise_deg=0.1,
                                  thrust_noise=0.02, rng=np.random.default_rng(seed))
        est = estimate_static(holds, sabertooth)
        value = np.r_[est.m_ext_kg, est.r_g_m]
        std = np.r_[est.m_ext_std_kg, est.r_g_std_m]
        hits += np.abs(value - truth) <= 1.96 * std
    coverage = hits / seeds
    assert np.all((coverage >= 0.90) & (coverage <= 0.99)), coverage


def test_level_holds_only_refuse_naming_z_g(sabertooth: Profile) -> None:
    W, r_g = payload_truth(sabertooth, 10.0, np.array([-1.0, 0.6, 0.0]))
    holds = equilibrium_holds(sabertooth, W, r_g, tilts_deg=((0, 0), (0, 0)),
                              attitude_noise_deg=0.1, thrust_noise=0.01)
    with pytest.raises(EstimationError, match="z_g is not identifiable: every hold was level"):
        estimate_static(holds, sabertooth)


def test_a_single_tilted_hold_is_refused_for_what_it_is(sabertooth: Profile) -> None:
    W, r_g = payload_truth(sabertooth, 10.0, np.array([-1.0, 0.6, 0.1]))
    holds = equilibrium_holds(sabertooth, W, r_g, tilts_deg=((20, 20),), thrust_noise=0.01)
    with pytest.raises(EstimationError, match=r"not identifiable .* two holds at different"):
        estimate_static(holds, sabertooth)


def test_rows_the_fit_drops_do_not_count_towards_identifiability(sabertooth: Profile) -> None:
    """Without the Z row, W − B shows only in the tilted hold's force rows, which the fit
    drops (a drifting vehicle): refuse, rather than print −5 ± 34 kg."""
    W, r_g = payload_truth(sabertooth, 10.0, np.array([-1.0, 0.6, 0.1]))
    holds = equilibrium_holds(sabertooth, W, r_g, thrust_noise=0.01)
    no_z = (True, True, False, True, True, True)
    with pytest.raises(EstimationError, match=r"W − B is not identifiable .*force rows count "
                                              r"at level holds only"):
        estimate_static(holds, sabertooth, dofs=no_z)
    est = estimate_static(holds, dataclasses.replace(sabertooth, holds_station=True), dofs=no_z)
    assert abs(est.m_ext_kg - 10.0) < 4 * est.m_ext_std_kg


def test_depth_hold_without_station_keeping_recovers_net_force(sabertooth: Profile) -> None:
    """At a tilt, only the vertical thrusters carry W − B: X = Y = 0 and body Z is
    (W − B)/(cosφ·cosθ) along the world vertical; the force rows together stay exact."""
    W, r_g = payload_truth(sabertooth, 10.0, np.array([-1.031, 0.6, 0.0]))
    holds = equilibrium_holds(sabertooth, W, r_g)
    tilted = holds[1]
    phi, theta = tilted.phi[0], tilted.theta[0]
    tau = tilted.tau.copy()
    tau[:, 0:2] = 0.0
    tau[:, 2] = -(W - sabertooth.buoyancy_N) / (np.cos(phi) * np.cos(theta))
    holds[1] = HoldSamples(tilted.t_s, tilted.phi, tilted.theta, tau, "drifting")
    est = estimate_static(holds, sabertooth)
    assert abs(est.m_ext_kg - 10.0) < 1e-3


def test_nan_samples_are_refused(sabertooth: Profile) -> None:
    W, r_g = payload_truth(sabertooth, 1.0, np.zeros(3))
    holds = equilibrium_holds(sabertooth, W, r_g)
    bad = holds[0].tau.copy()
    bad[3, 4] = np.nan
    holds[0] = HoldSamples(holds[0].t_s, holds[0].phi, holds[0].theta, bad, "hold 0")
    with pytest.raises(EstimationError, match="NaN"):
        estimate_static(holds, sabertooth)


def test_no_holds_refused(sabertooth: Profile) -> None:
    with pytest.raises(EstimationError, match="no steady hold"):
        estimate_static([], sabertooth)


def test_estimate_does_not_depend_on_centre_of_buoyancy_prior(sabertooth: Profile) -> None:
    """The net moments are the same whatever r_b the profile claims."""
    from dataclasses import replace

    W, r_g = payload_truth(sabertooth, 10.0, np.array([-1.031, 0.6, 0.0]))
    holds = equilibrium_holds(sabertooth, W, r_g)
    other = replace(sabertooth, r_b_m=(0.01, -0.02, -0.1))
    a, b = estimate_static(holds, sabertooth), estimate_static(holds, other)
    np.testing.assert_allclose(a.net_moment_Nm, b.net_moment_Nm, atol=1e-9)
    assert not np.allclose(a.r_g_m, b.r_g_m)


def test_all_rows_measurable_on_both_profiles(sabertooth: Profile, bluerov: Profile) -> None:
    assert measurable_dofs(sabertooth) == (True,) * 6
    assert measurable_dofs(bluerov) == (True,) * 6


def test_a_vehicle_without_pitch_actuation_measures_no_pitch_row(bluerov: Profile) -> None:
    """The standard BlueROV2 (6 thrusters, FRAME_CONFIG 1) cannot produce a pitch moment."""
    from dataclasses import replace

    six = replace(bluerov, thrusters=tuple(
        replace(t, position_m=(t.position_m[0] * 0, t.position_m[1], 0.0))
        if t.direction[2] else t for t in bluerov.thrusters[:6]))
    rows = measurable_dofs(six)
    assert rows[4] is False
    W, r_g = payload_truth(bluerov, 0.2, np.array([0.1, 0.0, 0.175]))
    est = estimate_static(equilibrium_holds(bluerov, W, r_g),
                          replace(bluerov, holds_station=True), dofs=rows)
    assert "M" not in est.dofs_used
    np.testing.assert_allclose(est.r_g_m, r_g, atol=1e-6)

