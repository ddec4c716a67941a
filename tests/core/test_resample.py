"""Zero-order hold: latest value at or before, never interpolated, gaps marked."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from trimd.core.errors import DataError
from trimd.core.resample import zoh_align


def test_holds_the_latest_value_without_look_ahead() -> None:
    a = zoh_align([0.0, 0.05, 0.1, 0.15, 0.2, 0.25], [0.0, 0.1, 0.2], [[1, 10], [2, 20], [3, 30]])
    np.testing.assert_array_equal(a.values[:, 0], [1, 1, 2, 2, 3, 3])
    np.testing.assert_array_equal(a.values[:, 1], [10, 10, 20, 20, 30, 30])
    np.testing.assert_allclose(a.age_s, [0, 0.05, 0, 0.05, 0, 0.05], atol=1e-12)


def test_before_first_source_and_gaps_are_invalid() -> None:
    a = zoh_align([0.0, 1.0, 1.4, 3.0], [0.5, 1.2], [5.0, 6.0], max_age_s=0.5)
    assert a.valid.tolist() == [False, True, True, False]
    assert np.isnan(a.values[0]) and np.isnan(a.values[3])


def test_bad_times_are_refused() -> None:
    with pytest.raises(DataError, match="non-decreasing"):
        zoh_align([0.0, 1.0], [1.0, 0.5], [1.0, 2.0])
    with pytest.raises(DataError, match="source times"):
        zoh_align([0.0], [0.0, 1.0], [1.0])


@given(st.lists(st.floats(0, 100), min_size=1, max_size=40),
       st.lists(st.floats(0, 100), min_size=1, max_size=40))
def test_value_is_always_a_past_source_sample(ref: list[float], src: list[float]) -> None:
    t_ref, t_src = np.sort(ref), np.sort(src)
    vals = np.arange(len(t_src), dtype=float)
    a = zoh_align(t_ref, t_src, vals)
    for t, v, ok in zip(t_ref, a.values, a.valid, strict=True):
        if ok:
            k = int(v)
            assert t_src[k] <= t  # never a future sample
            assert k == len(t_src) - 1 or t_src[k + 1] > t  # the latest one
        else:
            assert t < t_src[0]
