"""The change test: its threshold, false alarms without a change, detection of a step."""

from __future__ import annotations

import numpy as np
import pytest

from trimd.core.change import Baseline, ChangeDetector, threshold_for
from trimd.core.segment import SegmentEstimate


def _segment(k: int, q: np.ndarray, sigma: float) -> SegmentEstimate:
    cov = np.diag([sigma**2] * 3 + [0.0])
    return SegmentEstimate(f"segment {k}", 60.0 * k, 60.0 * k + 50, 0.0, 0.0, 500, q, cov,
                           cov, np.zeros((4, 2)), (True, True, True, False), True)


def _baseline(sigma: float) -> Baseline:
    return Baseline(np.zeros(4), np.full(4, (sigma / 10) ** 2), np.zeros((4, 2)), "test")


def test_threshold_grows_with_a_lower_false_alarm_rate() -> None:
    assert threshold_for(0.001, 60) > threshold_for(0.01, 60) > threshold_for(0.1, 60) > 0


def test_no_change_raises_about_the_designed_rate_of_false_alarms() -> None:
    """Gaussian segments without a change at a design rate of 1 per 100 segments."""
    h = threshold_for(0.6, 60)   # 0.01 per segment over the 6 one-sided tests
    sigma = 0.1
    det = ChangeDetector(_baseline(sigma), h)
    rng = np.random.default_rng(3)
    n = 3000
    alarms = sum(len(det.update(_segment(k, np.r_[sigma * rng.standard_normal(3), 0.0],
                                         sigma))) for k in range(n))
    # Siegmund's approximation: 30 expected; the baseline's own error shifts it a little
    assert 5 <= alarms <= 90, alarms


def test_a_step_is_found_soon_with_its_size_and_time() -> None:
    sigma, step = 0.1, 0.3
    det = ChangeDetector(_baseline(sigma), threshold_for(0.01, 60))
    rng = np.random.default_rng(4)
    alerts = []
    for k in range(200):
        q = np.r_[sigma * rng.standard_normal(3), 0.0]
        if k >= 100:
            q[0] += step
        alerts += [(k, a) for a in det.update(_segment(k, q, sigma))]
    first_k, first = alerts[0]
    assert first.component == 0 and first.first
    assert 100 <= first_k <= 110
    assert first.change == pytest.approx(step, abs=3 * first.change_std)
    assert first.total > 0
    assert first.since_s <= 60.0 * first_k and first.since_s >= 60.0 * 95


def test_a_significant_change_too_small_to_matter_is_not_alerted() -> None:
    sigma, step = 0.1, 0.3
    relevance = np.r_[0.0, 1.0, 1.0, 1.0]   # moments: only a change beyond 1 N·m matters
    det = ChangeDetector(_baseline(sigma), threshold_for(0.01, 60), relevance=relevance)
    rng = np.random.default_rng(5)
    alerts = []
    for k in range(200):
        q = np.r_[sigma * rng.standard_normal(3), 0.0]
        if k >= 100:
            q[1] += step    # 3σ, but below the relevance
        alerts += det.update(_segment(k, q, sigma))
    assert not any(a.component == 1 for a in alerts) and det.suppressed >= 1
