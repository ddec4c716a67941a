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
from trimd.core.hunting import EdgeObservation, hunting_spikes
from trimd.core.model import thrust_from_pwm
from trimd.core.profile import Profile, Thruster
from trimd.core.types import FloatArray

__all__ = ["OutputHistogram", "mean_thrust", "output_histogram", "spikes_seen"]


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


def mean_thrust(hist: OutputHistogram, thrusters: Sequence[Thruster],
                hunting: Sequence[EdgeObservation] = ()) -> FloatArray:
    """Each thruster's mean thrust [N] over the hold of ``hist``, its outputs read through
    ``thrusters``' curves at the hold's mean voltage, shape (n,); the samples of the
    ``hunting`` spikes delivered whatever balanced, counted at half the first µs's thrust
    whatever the curves (:func:`~trimd.core.hunting.hunting_factors` carries the rest)."""
    out = []
    for i, (t, p, c) in enumerate(zip(thrusters, hist.pwm_us, hist.counts, strict=True)):
        f = thrust_from_pwm(t.curve, p, hist.voltage_V)
        for o in hunting:
            if o.thruster == i:
                f = np.where(p == o.spike_us, o.step_N / 2, f)
        out.append(float(c @ f) / float(c.sum()))
    return np.array(out)


def spikes_seen(hist: OutputHistogram, profile: Profile) -> list[EdgeObservation]:
    """The hunting spikes of the hold of ``hist``
    (:func:`~trimd.core.hunting.hunting_spikes`)."""
    columns = [np.repeat(p, c.astype(int)) for p, c in zip(hist.pwm_us, hist.counts,
                                                            strict=True)]
    return hunting_spikes(np.stack(columns, axis=1), hist.voltage_V, profile)
