"""Dynamic identification on the simulated vehicle: excitation through the session, the
grey-box fit against the simulator's truth, validation on held-out data."""

from __future__ import annotations

import asyncio
import dataclasses

import numpy as np
import pytest

from drivers.sim.config import SimConfig
from drivers.sim.link import SimLink
from drivers.sim.vehicle import SimVehicle
from trimd.cmd_identify import run_experiment
from trimd.excitation import design_signal
from trimd.excite import Excite
from trimd.identify import FitOptions, fit_stage, nrmse, validate
from trimd.identify_data import experiments_from_samples
from trimd.identify_model import (
    HYDRO_NAMES,
    STAGES,
    lagged_thrust,
    prior_values,
)
from trimd.identify_report import profile_fragment
from trimd.procedure import Phase
from trimd.profile import Profile, parse_profile
from trimd.samples import Sample


def record(truth: Profile, design_profile: Profile, stage: str, duration: float, seed: int
           ) -> list[Sample]:
    """An excitation experiment of ``stage`` on a simulated vehicle built from ``truth``,
    designed from ``design_profile``, through Excite + Session (DVL on, default noise)."""
    sig = design_signal(design_profile, stage, duration_s=duration, seed=seed,
                        depth_excursion_m=20.0)
    vehicle = SimVehicle(truth, SimConfig(seed=seed, dvl=True, depth_m=40.0, attitude_hz=50.0,
                                           thrusters_hz=50.0, velocity_hz=50.0, depth_hz=50.0))
    excite = Excite(design_profile, sig, confirmed=True, depth_excursion_m=20.0)
    result, samples = asyncio.run(run_experiment(SimLink(vehicle), design_profile, excite))
    assert result.phase is Phase.DONE, result.reason
    return samples


def relative_errors(fit_values: dict[str, float], truth: Profile, names: tuple[str, ...]
                    ) -> dict[str, float]:
    true = prior_values(truth)
    return {n: abs(fit_values[n] - true[n]) / abs(true[n]) for n in names}


@pytest.fixture(scope="module")
def sabertooth_uvr(sabertooth: Profile) -> tuple[list[Sample], list[Sample]]:
    return (record(sabertooth, sabertooth, "uvr", 90.0, 1),
            record(sabertooth, sabertooth, "uvr", 60.0, 2))


def test_uvr_sabertooth_within_bounds_and_validates(
        sabertooth: Profile, sabertooth_uvr: tuple[list[Sample], list[Sample]]) -> None:
    fit_data, val_data = sabertooth_uvr
    fit = fit_stage(experiments_from_samples(fit_data, sabertooth), sabertooth, "uvr")
    err = relative_errors(fit.values(), sabertooth, STAGES["uvr"].free_names)
    damping = [n for n in err if "|" not in n and not n.endswith("dot")]
    # damping tight, masses looser on 90 s (docs/identification.md: mass bias)
    assert all(err[n] < 0.05 for n in damping), err
    assert all(err[n] < 0.15 for n in ("X_udot", "Y_vdot", "I_z+N_rdot")), err
    for n in ("X_u|u|", "Y_v|v|"):
        assert err[n] < 0.05, err
    # N_r|r| is negligible at these yaw rates: judge by its share of the yaw moment
    true_nrr = prior_values(sabertooth)["N_r|r|"]
    assert abs(fit["N_r|r|"].value - true_nrr) * fit.share["N_r|r|"] < 0.1
    val = validate(fit.values(), experiments_from_samples(val_data, sabertooth), sabertooth,
                   "uvr")
    assert min(min(v.nrmse) for v in val) >= 90.0, [v.nrmse for v in val]


def _different(profile: Profile) -> Profile:
    """A vehicle whose hydrodynamics differ from the shipped one (not tuned to it)."""
    return dataclasses.replace(
        profile, added_mass=(200.0, 60.0, 118.0, 0.0, 0.0, 0.0),
        inertia_kg_m2=(205.51, 930.58, 700.0),
        linear_damping=(-250.0, -150.0, -600.0, -1000.0, -10000.0, -2500.0),
        quadratic_damping=(-150.0, -1800.0, -2000.0, -1000.0, -10000.0, -8000.0))


def test_a_different_vehicle_is_identified_too(sabertooth: Profile) -> None:
    truth = _different(sabertooth)
    data = record(truth, sabertooth, "uvr", 90.0, 3)
    fit = fit_stage(experiments_from_samples(data, sabertooth), sabertooth, "uvr")
    err = relative_errors(fit.values(), truth, ("X_u", "Y_v", "N_r", "X_u|u|", "Y_v|v|",
                                                "X_udot", "Y_vdot", "I_z+N_rdot"))
    assert all(e < 0.2 for e in err.values()), err
    prior_err = relative_errors(prior_values(sabertooth), truth, tuple(err))
    assert sum(err.values()) < 0.2 * sum(prior_err.values())


def test_fragment_is_a_valid_profile_part(sabertooth: Profile) -> None:
    import yaml

    values = {n: v for n, v in prior_values(sabertooth).items()} | {"X_udot": 150.0,
                                                                    "N_r": -4000.0}
    frag = yaml.safe_load(profile_fragment(values, sabertooth))
    with open(sabertooth.source, encoding="utf-8") as f:
        base = yaml.safe_load(f)
    merged = parse_profile(base | frag, "merged")
    assert merged.added_mass[0] == pytest.approx(150.0)
    assert merged.linear_damping[5] == pytest.approx(-4000.0)
    assert merged.inertia_kg_m2 == sabertooth.inertia_kg_m2


def test_nrmse_matches_its_definition() -> None:
    rng = np.random.default_rng(0)
    y = rng.normal(size=(200, 2))
    y_hat = y + 0.1 * rng.normal(size=(200, 2))
    expect = [100 * (1 - np.linalg.norm(y[:, i] - y_hat[:, i])
                     / np.linalg.norm(y[:, i] - y[:, i].mean())) for i in range(2)]
    assert nrmse(y, y_hat) == pytest.approx(expect)


def test_lagged_thrust_is_the_exact_first_order_response() -> None:
    h, T = 0.02, 0.1
    tau = np.zeros((50, 6))
    tau[10:, 0] = 1.0      # acts from t_10 − h/2
    start, mid = lagged_thrust(tau, T, h)
    t = h * np.arange(50)
    switch = t[10] - h / 2
    expect = np.where(t >= switch, 1 - np.exp(-(t - switch) / T), 0.0)
    assert start[:, 0] == pytest.approx(expect, abs=1e-12)
    expect_mid = np.where(t + h / 2 >= switch, 1 - np.exp(-(t + h / 2 - switch) / T), 0.0)
    assert mid[:, 0] == pytest.approx(expect_mid, abs=1e-12)


def test_unknown_fixed_parameter_is_refused(sabertooth: Profile,
                                            sabertooth_uvr: tuple[list[Sample],
                                                                  list[Sample]]) -> None:
    from trimd.errors import EstimationError

    exps = experiments_from_samples(sabertooth_uvr[1], sabertooth)
    with pytest.raises(EstimationError, match="unknown parameters"):
        fit_stage(exps, sabertooth, "uvr", FitOptions(fixed={"X_uu": -1.0}))
    assert set(HYDRO_NAMES) >= set(STAGES["uvwpqr"].free_names)
