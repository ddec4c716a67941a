"""Steady-state tests of one stream: Cao–Rhinehart R (batch and streaming), drift t-test."""

from __future__ import annotations

import numpy as np

from trimd.core.steady import RatioTest, last_window_drift, ratio_statistic, window_drift


def test_ratio_is_near_one_for_white_noise_and_large_in_a_ramp() -> None:
    rng = np.random.default_rng(1)
    noise = rng.standard_normal(5000)
    R = ratio_statistic(noise)
    assert 0.8 < np.median(R[100:]) < 1.2
    ramp = np.linspace(0, 50, 300) + 0.1 * rng.standard_normal(300)
    assert np.all(ratio_statistic(ramp)[50:] > 2.5)


def test_ratio_uses_previous_filtered_mean() -> None:
    """ν²[1] = λ2·(x[1] − x_f[0])² with x_f[0] = x[0]: hand-computed for x = [0, 1]."""
    R = ratio_statistic([0.0, 1.0], lambda1=0.2, lambda2=0.1, lambda3=0.1)
    # ν² = 0.1·1, δ² = 0.1·1 → R = 1.8
    assert R[1] == np.float64(1.8)


def test_streaming_matches_batch() -> None:
    x = np.random.default_rng(2).standard_normal((300, 3)).cumsum(axis=0)
    test = RatioTest()
    streamed = np.array([test.update(v) for v in x])
    np.testing.assert_allclose(streamed, ratio_statistic(x), rtol=1e-12)


def test_drift_is_found_in_a_slow_ramp_and_not_in_noise() -> None:
    t = np.arange(2000) * 0.05
    rng = np.random.default_rng(3)
    flat = rng.standard_normal(2000)
    slow = flat + 0.5 * t
    assert np.mean(window_drift(t, flat, 5.0) > 0.5) < 0.01
    drift = window_drift(t, slow, 5.0)[200:]
    assert abs(np.median(drift) - 2.5) < 0.1  # slope 0.5/s over 5 s
    assert np.mean(drift > 0) > 0.99  # significant nearly everywhere


def test_the_last_samples_drift_is_the_whole_series_last_bit_for_bit() -> None:
    """The live test asks only the last sample's drift (the settling test's hot path):
    the same number as the whole series' last, exactly, at every length, with a window
    shorter or longer than the samples, for a ramp, noise, a constant and equal times."""
    rng = np.random.default_rng(4)
    for n in (1, 2, 3, 7, 50, 401):
        t = np.cumsum(rng.uniform(0.02, 0.15, n))
        for x in (rng.standard_normal((n, 3)), (0.3 * t)[:, None] + rng.standard_normal((n, 1)),
                  np.full((n, 2), 1.5), np.c_[t, -t]):
            for window in (0.05, 1.0, 5.0, 1e3):
                np.testing.assert_array_equal(last_window_drift(t, x, window),
                                              window_drift(t, x, window)[-1])
    t = np.r_[0.0, 0.1, 0.1, 0.1, 0.2]
    x = rng.standard_normal((5, 2))
    np.testing.assert_array_equal(last_window_drift(t, x, 0.1), window_drift(t, x, 0.1)[-1])
