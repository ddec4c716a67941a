"""A hold's thruster outputs kept as histograms (docs/method.md §7): per thruster, how many
of the hold's samples had each PWM [µs, rounded to 1 µs]. Enough for the hold's mean
thrust through any thrust curve, which is what a calibration fits
(:mod:`trimd.core.thrust_fit`), at a size a trim history can keep for every level hold.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trimd.core.estimate import HeldOutputs
from trimd.core.hunting import EdgeObservation, edge_observations
from trimd.core.model import thrust_from_pwm
from trimd.core.profile import Profile, Thruster
from trimd.core.types import FloatArray

__all__ = ["OutputHistogram", "edges_seen", "mean_thrust", "output_histogram"]


@dataclass(frozen=True, eq=False)
class OutputHistogram:
    """Per thruster (the profile's order) the distinct PWM outputs [µs] of a hold and how
    many samples had each; the hold's mean battery voltage [V]."""

    pwm_us: tuple[FloatArray, ...]
    counts: tuple[FloatArray, ...]
    voltage_V: float


def output_histogram(outputs: HeldOutputs) -> OutputHistogram:
    """The histogram of ``outputs`` (PWM rounded to whole µs, as MAVLink carries it)."""
    levels, counts = [], []
    for column in np.round(np.asarray(outputs.pwm_us, float)).T:
        values, n = np.unique(column, return_counts=True)
        levels.append(values.astype(float))
        counts.append(n.astype(float))
    return OutputHistogram(tuple(levels), tuple(counts), float(np.mean(outputs.voltage_V)))


def mean_thrust(hist: OutputHistogram, thrusters: Sequence[Thruster]) -> FloatArray:
    """Each thruster's mean thrust [N] over the hold of ``hist``, its outputs read through
    ``thrusters``' curves at the hold's mean voltage, shape (n,)."""
    return np.array([float(c @ thrust_from_pwm(t.curve, p, hist.voltage_V)) / float(c.sum())
                     for t, p, c in zip(thrusters, hist.pwm_us, hist.counts, strict=True)])


def edges_seen(hist: OutputHistogram, profile: Profile) -> list[EdgeObservation]:
    """The dead-band edges the hold of ``hist`` shows by hunting
    (:func:`~trimd.core.hunting.edge_observations`)."""
    columns = [np.repeat(p, c.astype(int)) for p, c in zip(hist.pwm_us, hist.counts,
                                                            strict=True)]
    return edge_observations(np.stack(columns, axis=1), hist.voltage_V, profile)
