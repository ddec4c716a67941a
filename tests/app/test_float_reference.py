"""A float as the thrust map's absolute reference (docs/method.md §7): a level hold of the
simulated Sabertooth whose thrust curves and ESC bands are off its profile
(``truth=perturbed``), then a float of the same vehicle, teach the thrust map what no
difference of two holds can: where the vertical thrusters' straight stretches lie. Judged
by the quantity the operator acts on: the net moments another level hold of the same
vehicle (another dive's noise) reads with what was learnt, against the TRUE vehicle."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from tests.helpers import sim_float_reference, sim_level_hold, sim_trim
from trimd.core.calibration import CalibrationHold, FloatReference, calibrate
from trimd.core.calibration_json import experiment_from_dict, experiment_to_dict
from trimd.core.errors import DataError, EstimationError
from trimd.core.float_reference import float_moments, reference_model
from trimd.core.profile import Profile
from trimd.core.segment import estimate_segment

OPTIONS = "disturb=real,truth=perturbed"
PAYLOAD = "10@AftSB"
#: The float's depth envelope [m]: the ballasted vehicle is near neutral, not at it.
EXCURSION_M = 10.0
#: Another dive of the same vehicle: its holds' noise and disturbances (seed + NOISE).
NOISE = 100_000


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 1])
def test_a_float_teaches_the_net_moments_another_hold_reads(sabertooth: Profile,
                                                            seed: int) -> None:
    made = sim_float_reference(sim_trim(sabertooth, PAYLOAD, seed, OPTIONS), PAYLOAD, seed,
                               seed, OPTIONS, EXCURSION_M)
    assert made.reference is not None, made.reason
    ballasted, q_true = made.payload, made.q_true
    model = reference_model(made.reference, sabertooth)
    learnt = calibrate([made.reference], sabertooth)
    assert [o.accepted for o in learnt.outcomes] == [True], learnt.outcomes[0].message
    other = sim_level_hold(sabertooth, ballasted, seed + NOISE, f"truth_seed={seed},{OPTIONS}")
    before = estimate_segment(other, sabertooth)
    after = estimate_segment(other, replace(sabertooth, thrust_map=learnt.posterior))
    mm_eq = 1e3 / sabertooth.weight_N
    err_before = np.abs(before.q[1:3] - q_true[1:3]) * mm_eq
    err_after = np.abs(after.q[1:3] - q_true[1:3]) * mm_eq
    sd_after = np.sqrt(np.diag(after.q_cov)[1:3]) * mm_eq
    print(f"seed {seed}: x, y net error {err_before.round(3)} → {err_after.round(3)} mm-eq "
          f"(± {sd_after.round(3)}); the reference's K, M ± "
          f"{(np.sqrt(np.diag(model.R)) * mm_eq).round(3)} mm-eq")
    assert np.all(err_after <= 1.96 * sd_after), (err_after, sd_after)
    assert np.all(sd_after < np.sqrt(np.diag(before.q_cov)[1:3]) * mm_eq)
    assert np.linalg.norm(err_after) < np.linalg.norm(err_before)


def test_the_float_moments_leave_no_restoring_moment_at_the_float() -> None:
    q = float_moments(math.radians(3.0), math.radians(-2.0), 450.0)
    assert q[2] == pytest.approx(450.0 * math.tan(math.radians(3.0)))
    assert q[1] == pytest.approx(450.0 * math.tan(math.radians(2.0)) / math.cos(
        math.radians(3.0)))


def test_a_hold_that_is_not_level_is_no_reference(sabertooth: Profile) -> None:
    n = len(sabertooth.thrusters)
    tilted = CalibrationHold("tilted hold", math.radians(10.0), 0.0, np.zeros(6),
                             np.eye(6), np.zeros(4 * n))
    ref = FloatReference("tilted → float", tilted, 0.0, 0.0, np.eye(2) * 1e-6, 450.0, 100.0)
    with pytest.raises(EstimationError, match="'tilted hold' is not level"):
        calibrate([ref], sabertooth)


def test_a_stored_reference_reads_back_and_a_malformed_one_is_named(
        sabertooth: Profile) -> None:
    n = len(sabertooth.thrusters)
    hold = CalibrationHold("verify 2", 0.01, -0.02, np.arange(6.0), np.eye(6),
                           np.ones(4 * n))
    ref = FloatReference("verify 2 → float 3", hold, 0.03, -0.01, np.diag([1e-6, 2e-6]),
                         450.0, 100.0)
    back = experiment_from_dict(json.loads(json.dumps(experiment_to_dict(ref))), "db")
    assert isinstance(back, FloatReference)
    assert (back.phi_rad, back.theta_rad, back.q_z, back.q_z_var) == (0.03, -0.01, 450.0,
                                                                     100.0)
    assert np.array_equal(back.angle_cov, ref.angle_cov)
    assert np.array_equal(back.hold.tau, hold.tau)
    broken = {**experiment_to_dict(ref), "float_angle_cov": [[1.0]]}
    with pytest.raises(DataError, match=r"db: float_angle_cov: shape \(1, 1\)"):
        experiment_from_dict(broken, "db")
    with pytest.raises(DataError, match="db: not a calibration experiment"):
        experiment_from_dict({"kind": "float", "label": "x"}, "db")
