"""Finding holds in a recording with the live settling test (one detector for both)."""

from __future__ import annotations

import math

import numpy as np

from tests.helpers import payload_truth
from trimd.core.holdfinder import find_holds
from trimd.core.model import restoring_forces
from trimd.core.profile import Profile
from trimd.core.samples import Attitude


def _recording(profile: Profile, plateaus: list[tuple[float, float, float]], *,
               attitude_hz: float, thruster_hz: float, seed: int = 0
               ) -> tuple[list[Attitude], np.ndarray, np.ndarray]:
    """Attitude plateaus (roll [deg], pitch [deg], duration [s]) joined by 5 s ramps, with
    the restoring effort of a 10 kg payload plus noise, at the given stream rates."""
    rng = np.random.default_rng(seed)
    W, r_g = payload_truth(profile, 10.0, np.array(profile.slots[0].position_m))
    knots_t, knots = [0.0], [plateaus[0][:2]]
    for roll, pitch, duration in plateaus:
        knots_t += [knots_t[-1] + 5.0, knots_t[-1] + 5.0 + duration]
        knots += [(roll, pitch), (roll, pitch)]
    end = knots_t[-1]
    path = np.radians(np.array(knots, dtype=float))

    def att(t: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(t, knots_t, path[:, 0]),
                                np.interp(t, knots_t, path[:, 1])])

    t_att = np.arange(0.0, end, 1 / attitude_hz)
    a = att(t_att) + np.radians(0.05) * rng.standard_normal((len(t_att), 2))
    rates = (att(t_att + 0.01) - att(t_att - 0.01)) / 0.02   # body rates ≈ Euler rates here
    attitude = [Attitude(float(t), float(p), float(q), 0.0, float(dp), float(dq), 0.0)
                for t, (p, q), (dp, dq) in zip(t_att, a, rates, strict=True)]
    t_thr = np.arange(0.0, end, 1 / thruster_hz) + 0.013
    truth = att(t_thr)
    tau = np.array([restoring_forces(p, q, W, profile.buoyancy_N, r_g, profile.r_b_m)
                    for p, q in truth])
    scale = np.r_[np.full(3, 20.0), np.full(3, 5.0)]
    return attitude, t_thr, tau + scale * rng.standard_normal(tau.shape)


def test_holds_are_found_at_the_rates_a_ground_station_leaves(sabertooth: Profile) -> None:
    """Attitude at 2 Hz and thrusters at 1 Hz (the batch detector found nothing here: the
    ratio test on thrusters repeated onto attitude times never settled)."""
    attitude, t, tau = _recording(sabertooth, [(0, 0, 90), (20, 20, 60)],
                                  attitude_hz=2.0, thruster_hz=1.0)
    holds = find_holds(attitude, t, tau, sabertooth)
    assert len(holds) == 2
    means = [(math.degrees(np.mean(h.phi)), math.degrees(np.mean(h.theta))) for h in holds]
    np.testing.assert_allclose(means, [(0, 0), (20, 20)], atol=0.1)
    # collected after min_steady_s of settling, inside each plateau
    assert holds[0].t_s[0] >= 5.0 + sabertooth.procedure.min_steady_s
    assert holds[0].t_s[-1] <= 95.0 and holds[1].t_s[0] >= 100.0


def test_plateaus_at_one_attitude_are_one_hold_and_ramps_are_none(sabertooth: Profile
                                                                   ) -> None:
    attitude, t, tau = _recording(sabertooth, [(0, 0, 40), (20, 20, 40), (0, 0, 40)],
                                  attitude_hz=10.0, thruster_hz=5.0)
    holds = find_holds(attitude, t, tau, sabertooth)
    assert [h.label for h in holds] == ["hold 1", "hold 2"]
    assert holds[0].t_s[-1] > 100.0   # the third plateau joined the first
    for h in holds:
        spread = np.degrees(np.ptp(h.phi))
        assert spread < 1.0, "no ramp sample was collected"


def test_a_log_without_thruster_outputs_has_no_holds(sabertooth: Profile) -> None:
    attitude, _, _ = _recording(sabertooth, [(0, 0, 60)], attitude_hz=10.0, thruster_hz=5.0)
    assert find_holds(attitude, np.empty(0), np.empty((0, 6)), sabertooth) == []
