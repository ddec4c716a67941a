"""Dead-band edges read from hunting outputs (:mod:`trimd.core.hunting`): a spike at the
innermost PWM of a side is an edge, outputs reported inside the band are not; on the
simulated Heavy whose ESC bands are off its profile's, the edges its held outputs show are
the true ones, and the thrust map conditioned on them covers the true offsets."""

from __future__ import annotations

import numpy as np
import pytest

from trimd.core.curve_error import BAND_SIGMA_SHARE
from trimd.core.hunting import (
    EDGE_STD_US,
    EdgeObservation,
    hunting_spikes,
    observed_bands,
    readable_edges,
)
from trimd.core.model import band_at
from trimd.core.profile import Profile
from trimd.drivers.sim.config import SimConfig, with_presets
from trimd.drivers.sim.vehicle import SimVehicle


def edges(pwm_us: np.ndarray, voltage_V: float, profile: Profile) -> list[EdgeObservation]:
    return readable_edges(hunting_spikes(pwm_us, voltage_V, profile), profile)


def _outputs(columns: dict[int, list[float]], n: int, samples: int = 200) -> np.ndarray:
    """``samples`` rows of PWM, neutral except ``columns`` (thruster → its values, cycled)."""
    pwm = np.full((samples, n), 1500.0)
    for i, values in columns.items():
        pwm[:, i] = np.resize(values, samples)
    return pwm


def test_spikes_at_the_innermost_pwm_of_both_sides_are_edges(bluerov: Profile) -> None:
    """A thruster whose outputs go through the band, seen only at a spike on each side,
    shows both edges; a spike on one side alone (an output resting just beyond the band),
    outputs reported inside the band, a spike beyond the margin and one too rare show
    none."""
    n, v = len(bluerov.thrusters), bluerov.nominal_voltage_V
    lo, hi = band_at(bluerov.thrusters[0].curve, v)        # 1472, 1528 µs
    hunting = [hi + 2] * 5 + [lo - 3] * 3 + [hi + 6, lo - 9]   # through the band
    seen = edges(_outputs({0: hunting}, n), v, bluerov)
    assert [(o.thruster, o.positive, o.edge_us, o.offset_us) for o in seen] == [
        (0, False, lo - 2.5, -2.5), (0, True, hi + 1.5, 1.5)]
    assert seen[1].share == pytest.approx(0.5) and seen[1].step_N > 0 > seen[0].step_N
    resting = [hi + 1] * 5 + [hi + 2]                       # 83 % at one PWM, one side
    across = [*np.arange(hi - 4, hi + 6, 1.0), lo - 3]     # reported inside the band
    far = [hi + 9] * 4 + [lo - 3] * 4                      # beyond the margin
    rare = [hi + 2] + [hi + 8] * 9 + [lo - 3] * 5
    outputs = _outputs({0: resting, 1: across, 2: far, 3: rare}, n)
    assert edges(outputs, v, bluerov) == []
    # each side on its own: resting at one PWM nearest the band, it may be hunting there
    assert [(o.thruster, o.spike_us, o.share) for o in hunting_spikes(outputs, v, bluerov)
            ] == [(0, hi + 1, pytest.approx(5 / 6, abs=0.01)), (2, lo - 3, 0.5),
                  (3, lo - 3, pytest.approx(1 / 3, abs=0.01))]


def test_a_lifting_thruster_shows_the_edge_of_one_side(bluerov: Profile) -> None:
    """A vertical thruster (it carries the payload: the hold needs its thrust) that stays
    at the PWM nearest its band shows that edge; a horizontal one resting so does not (the
    hold needs no thrust of it: it may rest in the band)."""
    n, v = len(bluerov.thrusters), bluerov.nominal_voltage_V
    lo, hi = band_at(bluerov.thrusters[4].curve, v)
    assert [t.direction[2] for t in bluerov.thrusters[4:]] == [1.0] * 4
    pinned = [hi + 2] * 19 + [hi + 4]
    seen = edges(_outputs({0: pinned, 4: pinned, 6: [lo - 1] * 20}, n), v, bluerov)
    assert [(o.thruster, o.positive, o.edge_us) for o in seen] == [
        (4, True, hi + 1.5), (6, False, lo - 0.5)]


def test_nothing_seen_leaves_the_thrust_map_as_it_was(bluerov: Profile) -> None:
    assert observed_bands(None, [], bluerov) is None


def test_conditioning_on_an_edge_moves_that_edge_alone(bluerov: Profile) -> None:
    n, v = len(bluerov.thrusters), bluerov.nominal_voltage_V
    lo, hi = band_at(bluerov.thrusters[2].curve, v)
    seen = [o for o in edges(_outputs({2: [hi + 3] * 3 + [lo] * 3}, n), v,
                                         bluerov) if o.positive]
    post = observed_bands(None, seen + seen, bluerov)   # one edge seen by two holds
    assert post is not None and post.experiments == 0
    k = 3 * n + 2
    sigma_band = bluerov.thrusters[2].curve.deadband_margin_us * BAND_SIGMA_SHARE
    prior_var, obs_var = 1.0, (EDGE_STD_US / sigma_band)**2
    assert post.mean[k] * sigma_band == pytest.approx(2.5 * prior_var / (prior_var + obs_var))
    assert post.cov[k, k] == pytest.approx(prior_var * obs_var / (prior_var + obs_var))
    others = np.delete(np.arange(4 * n), k)
    assert np.all(post.mean[others] == 0) and np.allclose(post.cov[np.ix_(others, others)],
                                                          np.eye(4 * n - 1))
    assert observed_bands(post, seen, bluerov) is post      # known that well already


@pytest.mark.parametrize("seed", [3, 4])
def test_the_simulated_heavy_s_held_outputs_show_its_true_edges(bluerov: Profile,
                                                                seed: int) -> None:
    """Held level in ALT_HOLD with 0.4 kg aboard, its ESC bands up to 4 µs off the
    profile's (``truth=perturbed``): every edge its outputs show is the true one (the last
    PWM of no thrust) within the 1 µs read, at least the horizontal thrusters' eight, and
    the posterior's 95 % interval of each band offset holds the truth."""
    config = with_presets(SimConfig(seed=seed, payload="0.4@W-aft-stbd", mode="ALT_HOLD"),
                          disturb="real", truth="perturbed")
    sim = SimVehicle(bluerov, config)
    sim.arm(True)
    sim.run_for(20.0)
    rows = []
    for _ in range(600):
        sim.run_for(0.1)
        rows.append(sim.sample("thrusters").pwm_us)
    v = sim.voltage_V
    seen = edges(np.array(rows), v, bluerov)
    assert len(seen) >= 8, seen
    true_offsets = np.array(sim.offset.band_offsets_us)
    for o in seen:
        true_edge = band_at(sim.true_profile.thrusters[o.thruster].curve, v)[int(o.positive)]
        assert abs(o.edge_us - true_edge) <= 0.5, (o, true_edge)
    post = observed_bands(None, seen, bluerov)
    assert post is not None
    n = len(bluerov.thrusters)
    sigma_band = np.array([t.curve.deadband_margin_us for t in bluerov.thrusters]
                          ) * BAND_SIGMA_SHARE
    truth = np.r_[true_offsets[:, 0], true_offsets[:, 1]] / np.tile(sigma_band, 2)
    sd = np.sqrt(np.diag(post.cov))[2 * n:]
    assert np.all(np.abs(post.mean[2 * n:] - truth) <= 1.96 * sd), (post.mean[2 * n:], truth)
    assert np.sum(sd < 0.5) >= 4
