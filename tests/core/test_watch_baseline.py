"""The watch's baseline on synthetic level hovers: formed from the first level segments
when they agree; when the trim moved while they were measured (a float torn off in the
first minutes), the disagreeing segments are left out, said so, and the baseline is the
level the vehicle holds after them, not a mean of levels it never had."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from tests.helpers import payload_truth
from trimd.app.watch import verdict
from trimd.core.change import baseline_from_segments
from trimd.core.errors import EstimationError
from trimd.core.model import pwm_from_thrust, restoring_forces, thrust_configuration
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Attitude, Depth, Health, ModeClass, Sample, Thrusters
from trimd.core.watch import TrimWatch

#: weight gained at STEP_S [N, s] (a float of 2 N of buoyancy lost)
STEP_N, STEP_S = 2.0, 100.0


def _hover(profile: Profile, extra_N: Callable[[float], float], seconds: float,
           seed: int = 0) -> list[Sample]:
    """A level hover at 5 m: attitude 10 Hz (0.05° noise), thrusters 4 Hz (the restoring
    effort of the vehicle with 0.3 kg at W-aft-ctr plus ``extra_N(t)`` [N] of weight
    at its centre of gravity, 1 % noise per thruster), depth 5 Hz, health 1 Hz."""
    W, r_g = payload_truth(profile, 0.3, np.array(profile.slot("W-aft-ctr").position_m))
    rng = np.random.default_rng(seed)
    T_pinv = np.linalg.pinv(thrust_configuration(profile.thrusters))
    volts = profile.nominal_voltage_V
    out: list[Sample] = []
    for k in range(int(seconds * 20)):
        t = k / 20
        if k % 20 == 0:
            out.append(Health(t, True, "ALT_HOLD", True, mode_class=ModeClass.DEPTH_HOLDING))
        if k % 4 == 0:
            out.append(Depth(t, 5.0 + 0.003 * rng.standard_normal()))
        if k % 5 == 0:
            g = restoring_forces(0.0, 0.0, W + extra_N(t), profile.buoyancy_N, r_g,
                                 profile.r_b_m)
            f = T_pinv @ g * (1 + 0.01 * rng.standard_normal(len(T_pinv)))
            out.append(Thrusters(t, tuple(float(pwm_from_thrust(th.curve, [fi], volts)[0])
                                          for th, fi in zip(profile.thrusters, f, strict=True))))
        if k % 2 == 0:
            noise = math.radians(0.05) * rng.standard_normal(2)
            out.append(Attitude(t, noise[0], noise[1], 0.0, 0.0, 0.0, 0.0))
    return out


def _watched(extra_N: Callable[[float], float]) -> TrimWatch:
    profile = load_profile("bluerov2-heavy")
    watch = TrimWatch(profile)
    for s in _hover(profile, extra_N, 300.0):
        watch.feed(s)
    watch.finish()
    return watch


@pytest.fixture(scope="module")
def stepped() -> TrimWatch:
    return _watched(lambda t: STEP_N if t >= STEP_S else 0.0)


def test_steady_segments_form_the_baseline_at_once() -> None:
    watch = _watched(lambda t: 0.0)
    assert watch.detector is not None and watch.baseline_dropped == []
    assert watch.detector.baseline.source == "the first 3 segments"
    assert watch.alerts == []


def test_segments_measured_while_the_trim_moved_are_left_out(stepped: TrimWatch) -> None:
    assert stepped.detector is not None
    dropped = stepped.baseline_dropped
    assert dropped and all("W − B ranged" in d for d in dropped), dropped
    base = stepped.detector.baseline
    first = int(dropped[-1].split(":")[0].split()[-1]) + 1
    assert base.source == f"segment {first} to segment {first + 2}"
    # the baseline's segments end after the step and it reads the level the vehicle
    # holds then, not a mean of the levels before and after
    used = [s for s in stepped.segments if s.estimate.label == f"segment {first}"]
    assert used[0].estimate.t_end_s > STEP_S, used[0].estimate
    profile = load_profile("bluerov2-heavy")
    W, _ = payload_truth(profile, 0.3, np.array(profile.slot("W-aft-ctr").position_m))
    net = W + STEP_N - profile.buoyancy_N
    assert abs(base.q[0] - net) < 3 * math.sqrt(base.var[0]) + 0.05, (base.q[0], net)


def test_the_verdict_names_the_segments_left_out(stepped: TrimWatch) -> None:
    text = verdict(stepped)
    assert "left out of the baseline" in text and stepped.baseline_dropped[0] in text


def test_disagreeing_segments_are_refused_with_why(stepped: TrimWatch) -> None:
    levels = [s.estimate for s in stepped.segments if s.baseline][:3]
    with pytest.raises(EstimationError, match=r"W − B ranged .* over 3 segments"):
        baseline_from_segments(levels, stepped.floor_var)


def test_after_as_many_drops_as_it_has_segments_the_baseline_forms_widened(
        stepped: TrimWatch) -> None:
    levels = [s.estimate for s in stepped.segments if s.baseline][:3]
    base = baseline_from_segments(levels, stepped.floor_var, widen=True)
    v = np.array([s.q_cov_noise[0, 0] for s in levels])
    w = (1 / v) / np.sum(1 / v)
    q = np.array([s.q[0] for s in levels])
    # its ± covers the scatter it was formed from
    assert base.var[0] > float(np.sum(w**2 * v))
    assert math.sqrt(base.var[0]) > 0.1 * np.ptp(q), (base.var[0], q)
    assert "widened to their scatter: W − B ranged" in base.source
    assert math.isclose(base.q[0], float(w @ q))
