"""The covariance of a mean of correlated samples: intervals that cover what they claim."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from trimd.core.longrun import mean_covariance

N_SERIES = 300


def _series(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """Zero-mean test series: white, white held for 2 or 3 samples (a slower stream
    zero-order held), or a slow AR(1) component (correlation time in samples) under
    white noise of half its amplitude."""
    if kind.startswith("zoh"):
        k = int(kind[3:])
        return np.repeat(rng.standard_normal(n // k + 1), k)[:n]
    white = rng.standard_normal(n)
    if kind == "white":
        return white
    rho = np.exp(-1 / float(kind[2:]))
    drive = np.sqrt(1 - rho**2) * rng.standard_normal(n)
    drive[0] = rng.standard_normal()
    return lfilter([1.0], [1.0, -rho], drive) + 0.5 * white


@pytest.mark.parametrize(("kind", "n"), [("white", 300), ("zoh2", 600), ("zoh3", 600),
                                          ("ar10", 600), ("ar50", 1200), ("ar120", 3000)])
def test_intervals_of_the_mean_cover_95_percent(kind: str, n: int) -> None:
    """Correlation times up to a twenty-fifth of the record: 95 % intervals cover 91–99 %
    of the time, and the variance is not overstated by more than 3× on average."""
    rng = np.random.default_rng(7)
    z, ratio = [], []
    for _ in range(N_SERIES):
        mc = mean_covariance(_series(kind, n, rng))
        z.append(mc.mean[0] / np.sqrt(mc.cov[0, 0]))
        ratio.append(mc.cov[0, 0])
    coverage = float(np.mean(np.abs(z) < 1.96))
    assert 0.91 <= coverage <= 0.99, coverage
    truth = np.var([_series(kind, n, rng).mean() for _ in range(N_SERIES)])
    assert np.mean(ratio) < 3 * truth


def test_a_slow_component_under_fast_noise_is_seen() -> None:
    """The case the kernel alone got wrong: 0.8 of the variance white, held for 2
    samples, the rest a correlation of 50 samples: the σ of its mean is neither too
    small nor much too large."""
    rng = np.random.default_rng(3)
    z = []
    for _ in range(N_SERIES):
        fast = np.repeat(rng.standard_normal(1501), 2)[:3000]
        slow = _series("ar50", 3000, rng) * 0.5
        mc = mean_covariance(np.column_stack([fast + slow, fast]))
        z.append(mc.mean[0] / np.sqrt(mc.cov[0, 0]))
    assert 0.7 < np.sqrt(np.mean(np.square(z))) < 1.2


def test_too_short_a_record_is_flagged() -> None:
    """100 samples of a correlation 50 samples long are not 10 independent ones."""
    slow = _series("ar50", 100, np.random.default_rng(1))
    assert not mean_covariance(slow).resolved
    assert mean_covariance(np.random.default_rng(1).standard_normal(100)).resolved
