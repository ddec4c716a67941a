"""The thrust map fitted to calibration experiments (docs/method.md §7): experiments whose
holds' outputs went through TRUE curves (gains and ESC bands off, as
:mod:`trimd.core.curve_error` models them) must be reproduced by the fit, whose ± must
cover the true errors; a hold's outputs must survive the history's JSON; a hold read
through the fitted curves must move by what the fitted curves deliver."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from trimd.core.calibration import CalibrationHold, posterior
from trimd.core.calibration_json import hold_from_dict, hold_to_dict
from trimd.core.curve_error import thrusters_with_errors
from trimd.core.errors import DataError
from trimd.core.estimate import HeldOutputs, HoldSamples
from trimd.core.learnt import band_edges, gains
from trimd.core.model import band_at, thrust_configuration, thrusts_from_pwm
from trimd.core.output_hist import mean_thrust, output_histogram
from trimd.core.profile_yaml import load_profile
from trimd.core.systematics import thrust_map_bias
from trimd.core.thrust_fit import ChangeModel, Gaussian, fit, innovation, predicted

PROFILE = load_profile("bluerov2-heavy")
ROWS = np.array([False, False, True, True, True, False])
N = len(PROFILE.thrusters)


def outputs(rng: np.random.Generator, samples: int = 400) -> HeldOutputs:
    """Outputs hunting about each thruster's band edges and beyond, integer µs."""
    v = PROFILE.nominal_voltage_V
    pwm = np.empty((samples, N))
    for i, t in enumerate(PROFILE.thrusters):
        lo, hi = band_at(t.curve, v)
        centre = rng.choice([lo - 15, hi + 15, lo, hi, 1500.0])
        pwm[:, i] = np.round(centre + rng.normal(0, 12, samples))
    return HeldOutputs(pwm, np.full(samples, v))


def experiments(z_true: np.ndarray, rng: np.random.Generator, count: int,
                sigma: float) -> list[ChangeModel]:
    """``count`` experiments whose targets are what the true curves (errors ``z_true``)
    make of their holds' outputs, measured to ``sigma`` [N, N·m] (R's 1σ)."""
    true = thrusters_with_errors(PROFILE, z_true)
    T = thrust_configuration(PROFILE.thrusters)[ROWS]
    out = []
    for k in range(count):
        before, after = output_histogram(outputs(rng)), output_histogram(outputs(rng))
        change = T @ (mean_thrust(after, true) - mean_thrust(before, true))
        measured = T @ (mean_thrust(after, PROFILE.thrusters)
                        - mean_thrust(before, PROFILE.thrusters))
        out.append(ChangeModel(f"experiment {k}", ROWS, change + rng.normal(0, sigma, 3),
                               sigma**2 * np.eye(3), T, before, after, measured,
                               np.zeros((3, 4 * N))))
    return out


def test_the_check_sees_a_band_edge_move_an_output_resting_inside_the_band() -> None:
    """A vertical thruster resting 2 µs inside its table's band gives no thrust at z = 0,
    nor a hair away: the tangent would say its edge cannot move the prediction. An edge
    1σ earlier gives it thrust, one 1σ later none, so the check's Jacobian, the secant
    over ± 1σ, moves the predicted Z by half that thrust per σ."""
    v, samples = PROFILE.nominal_voltage_V, 100
    _, hi = band_at(PROFILE.thrusters[4].curve, v)
    at_rest = np.full((samples, N), 1500.0)
    resting = at_rest.copy()
    resting[:, 4] = hi - 2
    before, after = (output_histogram(HeldOutputs(p, np.full(samples, v)))
                     for p in (at_rest, resting))
    T = thrust_configuration(PROFILE.thrusters)[ROWS]
    model = ChangeModel("rest", ROWS, np.zeros(3), 1e-6 * np.eye(3), T, before, after,
                        np.zeros(3), np.zeros((3, 4 * N)))
    k = 3 * N + 4                                   # thruster 5's upper edge
    cov = np.zeros((4 * N, 4 * N))
    cov[k, k] = 1.0
    _, S = innovation(model, PROFILE, np.zeros(4 * N), cov)
    earlier = np.zeros(4 * N)
    earlier[k] = -1.0
    delivered = mean_thrust(after, thrusters_with_errors(PROFILE, earlier))[4]
    assert mean_thrust(after, PROFILE.thrusters)[4] == 0.0 and delivered > 0.01
    assert np.sqrt(S[0, 0] - 1e-6) == pytest.approx(abs(T[0, 4]) * delivered / 2)


def test_a_hold_histogram_gives_the_mean_thrust_of_its_samples() -> None:
    held = outputs(np.random.default_rng(1))
    hist = output_histogram(held)
    assert np.allclose(mean_thrust(hist, PROFILE.thrusters),
                       thrusts_from_pwm(PROFILE, held.pwm_us).mean(axis=0), rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_fit_reproduces_experiments_of_true_curves_and_its_interval_covers_them(
        seed: int) -> None:
    rng = np.random.default_rng(seed)
    z_true = rng.standard_normal(4 * N)
    models = experiments(z_true, rng, 12, sigma=0.05)
    mean, cov = fit(models, PROFILE, Gaussian(np.zeros(4 * N), np.eye(4 * N)), np.zeros(4 * N))
    fitted = thrusters_with_errors(PROFILE, mean)
    # the fitted curves reproduce every experiment to its noise
    misfit = [(predicted(m, fitted, mean) - m.target) / 0.05 for m in models]
    assert np.sqrt(np.mean(np.square(misfit))) < 2.0
    # and what they predict of a new hold pair is the truth's, within its ±
    check = experiments(z_true, rng, 1, sigma=0.0)[0]
    J = np.array([(predicted(check, thrusters_with_errors(PROFILE, mean + 1e-4 * e),
                             mean + 1e-4 * e) - predicted(check, fitted, mean)) / 1e-4
                  for e in np.eye(4 * N)]).T
    error = predicted(check, fitted, mean) - check.target
    std = np.sqrt(np.diag(J @ cov @ J.T))
    assert np.all(np.abs(error) <= 4 * std + 1e-6), (error, std)
    # the data narrowed the errors they reach: the posterior is tighter than the prior
    assert np.trace(cov) < 0.9 * 4 * N


def test_a_hold_read_through_the_fitted_curves_moves_by_what_they_deliver() -> None:
    rng = np.random.default_rng(7)
    z = rng.standard_normal(4 * N)
    held = outputs(rng)
    thrust = thrusts_from_pwm(PROFILE, held.pwm_us, held.voltage_V)
    T = thrust_configuration(PROFILE.thrusters)
    hold = HoldSamples(np.arange(len(thrust), dtype=float), np.zeros(len(thrust)),
                       np.zeros(len(thrust)), thrust @ T.T, "level", thrust, held)
    calibrated = replace(PROFILE, thrust_map=posterior(z, np.eye(4 * N), 1))
    true = thrusts_from_pwm(replace(PROFILE, thrusters=thrusters_with_errors(PROFILE, z)),
                            held.pwm_us, held.voltage_V)
    bias = thrust_map_bias([hold], [ROWS], calibrated)[0]
    assert np.allclose(bias, T[ROWS] @ (true - thrust).mean(axis=0), atol=1e-9)
    assert np.abs(bias).max() > 0.1  # the errors move it measurably


def test_a_hold_keeps_its_outputs_through_the_history_json_and_a_bad_one_is_refused() -> None:
    held = output_histogram(outputs(np.random.default_rng(3)))
    hold = CalibrationHold("trim 1, level", 0.01, -0.02, np.zeros(6), np.eye(6),
                           np.zeros(4 * N), held)
    back = hold_from_dict(hold_to_dict(hold), "test")
    assert back.outputs is not None
    assert np.allclose(mean_thrust(back.outputs, PROFILE.thrusters),
                       mean_thrust(held, PROFILE.thrusters), rtol=0, atol=1e-12)
    d = hold_to_dict(hold)
    d["outputs"]["counts"][2] = d["outputs"]["counts"][2][:-1]  # type: ignore[index]
    with pytest.raises(DataError, match="outputs"):
        hold_from_dict(d, "test")


def test_what_a_calibration_learnt_is_said_in_the_units_of_each_parameter() -> None:
    z = np.zeros(4 * N)
    z[2 * N + 1], z[3 * N + 1] = 1.0, -2.0  # the second thruster's band edges, in prior σ
    cov = np.eye(4 * N)
    cov[3 * N + 1, 3 * N + 1] = 0.25
    edges = {(b.thruster, b.edge): b for b in band_edges(posterior(z, cov, 1), PROFILE)}
    name = PROFILE.thrusters[1].name
    s = PROFILE.thrusters[1].curve.deadband_margin_us / np.sqrt(3)
    low, high = edges[(name, "low")], edges[(name, "high")]
    assert np.isclose(low.mean_us, s) and np.isclose(high.mean_us, -2 * s)
    assert np.isclose(high.std_us, 0.5 * s) and high.determined and not low.determined
    assert not any(g.determined for g in gains(posterior(z, cov, 1), PROFILE))
