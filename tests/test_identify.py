"""Dynamic identification on the simulated vehicle: excitation through the session, the
grey-box fit against the simulator's truth, validation on held-out data."""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from drivers.sim.config import SimConfig
from drivers.sim.link import SimLink
from drivers.sim.vehicle import SimVehicle
from trimd.cmd_identify import run_experiment
from trimd.excitation import design_signal
from trimd.excite import Excite
from trimd.identify import FitOptions, StageFit, Validation, fit_stage, nrmse, validate
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
from trimd.samples import Attitude, Sample


def record(truth: Profile, design_profile: Profile, stage: str, duration: float, seed: int,
           recorder: Any = None) -> list[Sample]:
    """An excitation experiment of ``stage`` on a simulated vehicle built from ``truth``,
    designed from ``design_profile``, through Excite + Session (DVL on, default noise),
    written to ``recorder`` when given."""
    sig = design_signal(design_profile, stage, duration_s=duration, seed=seed,
                        depth_excursion_m=20.0)
    vehicle = SimVehicle(truth, SimConfig(seed=seed, dvl=True, depth_m=40.0, attitude_hz=50.0,
                                           thrusters_hz=50.0, velocity_hz=50.0, depth_hz=50.0))
    excite = Excite(design_profile, sig, confirmed=True, depth_excursion_m=20.0)
    result, samples = asyncio.run(run_experiment(SimLink(vehicle), design_profile, excite,
                                                 recorder=recorder))
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


def _judge(fit: StageFit, truth: Profile, bound: float) -> dict[str, float]:
    """The free hydrodynamic parameters of the stage that miss the issue's criterion with
    ``bound`` in place of 10 %: relative error, or, for a coefficient that is negligible
    (its whole contribution below 10 % of its DOF's force or moment at the experiment's
    typical motion, zero included), the share its error makes of that force or moment."""
    true = prior_values(truth)
    bad = {}
    for n in STAGES[fit.stage].free_names:
        error = abs(fit[n].value - true[n])
        negligible = abs(true[n]) * fit.share[n] < 0.1
        judged = error * fit.share[n] if negligible else error / abs(true[n])
        if judged > bound:
            bad[n] = judged
    return bad


def _fit_and_validate(truth: Profile, stage: str, fit_s: float, val_s: float,
                      design: Profile | None = None) -> tuple[StageFit, list[Validation]]:
    design = design or truth
    fit = fit_stage(experiments_from_samples(record(truth, design, stage, fit_s, 5), design),
                    design, stage)
    val = validate(fit.values(), experiments_from_samples(
        record(truth, design, stage, val_s, 6), design), design, stage)
    return fit, val


def test_uwq_sabertooth_short_run(sabertooth: Profile) -> None:
    fit, val = _fit_and_validate(sabertooth, "uwq", 60.0, 30.0)
    assert not _judge(fit, sabertooth, 0.2), fit.values()
    assert min(min(v.nrmse) for v in val) >= 85.0, [v.nrmse for v in val]


def test_uvwpqr_sabertooth_short_run(sabertooth: Profile) -> None:
    fit, val = _fit_and_validate(sabertooth, "uvwpqr", 60.0, 30.0)
    assert not _judge(fit, sabertooth, 0.2), fit.values()
    assert min(min(v.nrmse) for v in val) >= 85.0, [v.nrmse for v in val]


def test_bluerov_is_excited_within_the_envelope_and_identified(bluerov: Profile) -> None:
    # its horizontal thrusters sit below the CG: open loop, surge and sway tip it over
    samples = record(bluerov, bluerov, "uvwpqr", 60.0, 5)
    tilt = max(max(abs(s.phi), abs(s.theta)) for s in samples if isinstance(s, Attitude))
    assert math.degrees(tilt) < bluerov.procedure.max_tilt_deg
    fit = fit_stage(experiments_from_samples(samples, bluerov), bluerov, "uvwpqr")
    assert not _judge(fit, bluerov, 0.2), fit.values()
    val = validate(fit.values(), experiments_from_samples(
        record(bluerov, bluerov, "uvwpqr", 30.0, 6), bluerov), bluerov, "uvwpqr")
    assert min(min(v.nrmse) for v in val) >= 85.0, [v.nrmse for v in val]


def _different(profile: Profile) -> Profile:
    """A vehicle whose hydrodynamics differ from the shipped one (not tuned to it): every
    parameter a stage identifies is at least 25 % away from its shipped value."""
    return dataclasses.replace(
        profile, added_mass=(200.0, 60.0, 250.0, 40.0, 150.0, 0.0),
        inertia_kg_m2=(260.0, 1150.0, 700.0),
        linear_damping=(-250.0, -150.0, -400.0, -1500.0, -7000.0, -2500.0),
        quadratic_damping=(-150.0, -1800.0, -3000.0, -600.0, -15000.0, -8000.0))


@pytest.mark.parametrize("stage", list(STAGES))
def test_a_different_vehicle_is_identified_too(sabertooth: Profile, stage: str) -> None:
    """Excitation designed from, and the fit given, the shipped profile; the simulated
    vehicle is another one: the fit must find the other one's values."""
    truth = _different(sabertooth)
    names = STAGES[stage].free_names
    prior_err = relative_errors(prior_values(sabertooth), truth, names)
    assert min(prior_err.values()) >= 0.25, prior_err
    fit, val = _fit_and_validate(truth, stage, 60.0, 30.0, design=sabertooth)
    assert not _judge(fit, truth, 0.2), fit.values()
    assert min(min(v.nrmse) for v in val) >= 85.0, [v.nrmse for v in val]
    err = relative_errors(fit.values(), truth, names)
    assert sum(err.values()) < 0.2 * sum(prior_err.values()), err


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


def test_identify_writes_fragment_summary_and_png_plots(sabertooth: Profile,
                                                        tmp_path: Path) -> None:
    """`trimd identify --out` on recorded logs: the YAML, the JSON and one PNG per
    validation log, each a PNG that decodes to a plotted image."""
    import json

    from matplotlib.image import imread

    from replay.recorder import TlogRecorder
    from trimd.cmd_identify import run_identify

    logs = []
    for seed, duration in ((7, 30.0), (8, 20.0)):
        path = tmp_path / f"uvr-{seed}.tlog"
        recorder = TlogRecorder(path, sabertooth,
                                Path(sabertooth.source).read_text(encoding="utf-8"))
        record(sabertooth, sabertooth, "uvr", duration, seed, recorder=recorder)
        logs.append(str(path))
    out = tmp_path / "out"
    args = argparse.Namespace(logs=logs[:1], validate=logs[1:], profile=sabertooth.source,
                              stage="uvr", segment=FitOptions.segment_s, out=str(out))
    assert run_identify(args) == 0
    assert (out / "fragment.yaml").is_file()
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["stages"]["uvr"]["validation"]
    pngs = sorted(out.glob("*.png"))
    assert len(pngs) == len(summary["stages"]["uvr"]["validation"])
    for png in pngs:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        image = imread(png)
        assert image.shape[0] > 300 and image.shape[1] > 600
        assert float(image[..., :3].std()) > 0.05      # not a blank canvas
