"""Zero-order-hold alignment of slower streams onto a reference time base.

Thruster outputs arrive slower than attitude (ArduSub: SERVO_OUTPUT_RAW 2–10 Hz,
ATTITUDE 10–20 Hz). Each reference sample takes the latest source value at or before its
own time: no interpolation, no look-ahead (docs/method.md §3). A reference sample whose latest
source value is older than ``max_age_s`` is marked invalid instead of being bridged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trimd.core.errors import DataError

__all__ = ["Aligned", "zoh_align"]


@dataclass(frozen=True, eq=False)
class Aligned:
    """Source values held onto the reference times.

    Attributes
    ----------
    values : shape ``(N,) + source value shape``; NaN where ``valid`` is False.
    valid : True where a source sample at or before the reference time exists and is at
        most ``max_age_s`` old.
    age_s : age of the held source sample [s] (inf where there is none).
    """

    values: NDArray[np.float64]
    valid: NDArray[np.bool_]
    age_s: NDArray[np.float64]


def zoh_align(t_ref: ArrayLike, t_src: ArrayLike, values: ArrayLike, *,
              max_age_s: float = np.inf) -> Aligned:
    """Hold each source value until the next one: the value at ``t_ref[i]`` is the last
    source sample with ``t_src <= t_ref[i]``.

    Parameters
    ----------
    t_ref : reference times [s], non-decreasing.
    t_src : source times [s], non-decreasing.
    values : source values, first axis along ``t_src``.
    max_age_s : a held value older than this [s] marks a gap (invalid), not bridged.

    Examples
    --------
    >>> a = zoh_align([0.0, 0.1, 0.2, 0.5], [0.05, 0.2], [1.0, 2.0], max_age_s=0.2)
    >>> a.values.tolist(), a.valid.tolist()
    ([nan, 1.0, 2.0, nan], [False, True, True, False])
    """
    ref = np.asarray(t_ref, float)
    src = np.asarray(t_src, float)
    vals = np.asarray(values, float)
    if vals.shape[:1] != src.shape:
        raise DataError(f"zoh_align: {len(src)} source times but {vals.shape[0]} values")
    for name, t in (("reference", ref), ("source", src)):
        if t.ndim != 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise DataError(f"zoh_align: {name} times must be finite and non-decreasing")
    idx = np.searchsorted(src, ref, side="right") - 1
    have = idx >= 0
    age = np.full(ref.shape, np.inf)
    age[have] = ref[have] - src[idx[have]]
    valid = have & (age <= max_age_s)
    out = np.full(ref.shape + vals.shape[1:], np.nan)
    out[valid] = vals[idx[valid]]
    return Aligned(out, valid, age)
