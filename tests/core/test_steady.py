"""Steady-state detector: Cao–Rhinehart R, drift t-test, segments in sample time."""

from __future__ import annotations

import numpy as np

from trimd.core.steady import (
    RatioTest,
    SteadyCriteria,
    detect_steady,
    ratio_statistic,
    steady_segments,
    window_drift,
)


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


def test_segments_respect_minimum_duration_and_gaps() -> None:
    t = np.r_[np.arange(100) * 0.1, 20 + np.arange(100) * 0.1]
    mask = np.ones(200, bool)
    mask[30] = False
    segments = steady_segments(t, mask, 5.0)
    # 0–2.9 s is too short; 3.1–29.9 s runs across the time gap in a plain mask ...
    assert [(s.start, s.stop) for s in segments] == [(31, 200)]
    # ... but detect_steady restarts at the gap
    x = np.random.default_rng(4).standard_normal((200, 2))
    _, segs = detect_steady(t, x, SteadyCriteria(min_duration_s=5.0))
    assert all(s.stop <= 100 or s.start >= 100 for s in segs)


def test_detects_the_settled_part_of_a_step_response() -> None:
    t = np.arange(3000) * 0.1
    settle = 20 * (1 - np.exp(-t / 15.0))
    rng = np.random.default_rng(5)
    x = np.column_stack([settle, 2 * settle]) + 0.05 * rng.standard_normal((3000, 2))
    mask, segments = detect_steady(t, x, SteadyCriteria(min_duration_s=20.0,
                                                        drift_tol=(0.2, 0.4)))
    assert segments, "the settled tail must be found"
    first = segments[0]
    true_drift = 20 / 15.0 * np.exp(-t[first.start] / 15.0) * 5.0  # slope × window
    assert 0.05 < true_drift < 0.2 * 1.5  # steady once the drift falls to its tolerance
    assert not mask[t < 30].any()  # nothing during the transient


def test_resolution_floor_keeps_a_quantised_still_signal_steady() -> None:
    """A still vehicle logged in 0.01° steps sits on one step and flips to the next now
    and then (a sticky flip): the bare ratio calls every flip a transient."""
    rng = np.random.default_rng(6)
    q = np.radians(0.01)
    t = np.arange(600) * 0.5
    x = (np.cumsum(rng.random((600, 2)) < 0.05, axis=0) % 2) * q
    bare = SteadyCriteria(min_duration_s=20.0)
    floored = SteadyCriteria(min_duration_s=20.0, resolution=(q, q))
    assert not detect_steady(t, x, bare)[1]
    assert detect_steady(t, x, floored)[1], "the still signal is steady"
    ramp = x + np.linspace(0, 0.2, 600)[:, None]  # a real transient still is one
    assert not detect_steady(t, ramp, floored)[0][100:].any()
