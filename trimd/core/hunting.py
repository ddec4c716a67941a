"""Where each ESC's dead band really starts, read from a hold's outputs (docs/method.md
§3, "The thrust map near the dead band").

A thruster whose output falls inside its ESC's dead band while the autopilot holds the
vehicle hunts at the band's edge: the integrator winds the output out of the band until
thrust appears, the vehicle answers, the output falls back; the thrust delivered is
whatever balances. The outputs then pile up at the first PWM that gives thrust: the true
edge, which the profile's table knows only to ± its ``deadband_margin_us``. Beyond the
band a T200's thrust grows from zero at that edge (≈ 0.08 N per µs), so an edge a few µs
off moves every output's thrust by the slope times the offset: most of the thrust map's
error near neutral (a T200's 5 % gain is 0.05 N at 1 N).

:func:`hunting_spikes` finds such pile-ups, hunting spikes, in one hold: on each side
of neutral, the PWM nearest the band that the hold's outputs show (nothing between it and
neutral), within the margin (+1 µs) of the table's edge, holding at least
:data:`SPIKE_SHARE` of the hold's samples and :data:`SPIKE_RATIO` times as many as the
PWM beside it. :func:`readable_edges` says which show an edge:

* a spike on each side of one thruster: its output went through the band and was never
  seen inside it;
* any spike of a thruster that carries the vehicle's weight (:data:`LIFTING`): the hold
  needs its thrust, so an output of it that stays at the band's edge is hunting for the
  thrust that balances. On 40 simulated perturbed Heavies' calibration series every such
  spike, 288 of them, lay within 0.5 µs of the true edge (offline, by a script not in the
  repository; ``tests/core/test_hunting.py`` checks every edge read on two seeds).

A spike on one side alone of any other thruster may be an output that rests steadily at
the band, inside it or just beyond (the exact simulated Heavy's horizontal thrusters held
level with 0.3 kg aboard: 97 % at 1528 µs, the last PWM of no thrust; a version that read
them as edges left the ballast proposed for it 1.5° off level in roll, and
``test_trim_on_the_simulated_vehicle`` failed), which says nothing of where the
band starts, though it may be hunting: the hold needs no thrust of it. Outputs that hunt
were reported where they hunted, at the first PWM of thrust (as the simulator's
``esc_hunt`` reports them): the true edge, the last PWM of no thrust, lies in the 1 µs
before the spike, at its middle ± :data:`EDGE_STD_US`. An output reported as commanded,
inside the band too, shows no spikes and teaches nothing: the profile's ± stays.

:func:`observed_bands` conditions the thrust map's Gaussian (the profile's prior, or its
calibration) on the edges that a set of holds shows; what the samples of every spike
delivered, whatever balanced, stays uncertain by up to the first µs's thrust
(:func:`hunting_factors`), and a calibration does not read the curves from them
(:func:`~trimd.core.output_hist.mean_thrust`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trimd.core.curve_error import error_scales
from trimd.core.map_posterior import ThrustMapPosterior, posterior, prior
from trimd.core.model import band_at, thrust_configuration, thrust_from_pwm
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

__all__ = ["EDGE_STD_US", "LIFTING", "SPIKE_RATIO", "SPIKE_SHARE", "EdgeObservation",
           "hunting_factors", "hunting_spikes", "observed_bands", "readable_edges"]

#: Least share of a hold's samples at one PWM for a hunting spike.
SPIKE_SHARE = 0.2
#: Least ratio of a spike's samples to those of each PWM beside it.
SPIKE_RATIO = 3.0
#: Least vertical share of a thruster's thrust (the z component of its unit direction)
#: for a spike on one side alone to show its edge: it carries the vehicle's weight.
LIFTING = 0.7
#: 1σ of an edge read from a spike [µs]: the edge lies anywhere in the 1 µs before the
#: spike's PWM (uniform: 0.29 µs), rounded up for an ESC whose edge moves with its
#: temperature and voltage between holds.
EDGE_STD_US = 0.5


@dataclass(frozen=True)
class EdgeObservation:
    """One ESC's dead-band edge as a hold's outputs show it.

    Attributes
    ----------
    thruster : its index (the profile's order).
    positive : the edge above neutral (else the one below).
    spike_us : the spike's PWM [µs].
    edge_us : the last PWM of no thrust [µs]: the spike's PWM ∓ 0.5 µs
        (± :data:`EDGE_STD_US`).
    offset_us : how far that lies from the profile's table edge at the hold's voltage [µs]
        (positive: later in PWM, as :func:`~trimd.core.curve_error.offset_band`).
    share : the hold's samples at the spike, a share of all.
    step_N : the thrust of the first µs beyond the table's edge [N, signed]: what a
        hunting sample delivers lies anywhere between zero and this.
    """

    thruster: int
    positive: bool
    spike_us: float
    edge_us: float
    offset_us: float
    share: float
    step_N: float


def hunting_spikes(pwm_us: ArrayLike, voltage_V: float, profile: Profile
                   ) -> list[EdgeObservation]:
    """Every hunting spike (module docstring) of the outputs ``pwm_us`` of one hold, each
    side on its own, shape (N, n) [µs] in the profile's thruster order, at the hold's mean
    battery voltage ``voltage_V`` [V]: what those samples delivered is whatever balanced
    (:func:`hunting_factors`), whether the edge can be read or not
    (:func:`readable_edges`)."""
    pwm = np.round(np.asarray(pwm_us, float))
    found = []
    for i, t in enumerate(profile.thrusters):
        for positive, table_edge in zip((False, True), band_at(t.curve, voltage_V),
                                        strict=True):
            spike = _spike(pwm[:, i], positive, table_edge, t.curve.neutral_us,
                           t.curve.deadband_margin_us + 1)
            if spike is None:
                continue
            inner, share = spike
            step = float(thrust_from_pwm(t.curve, table_edge + (1 if positive else -1),
                                         voltage_V))
            edge = inner - 0.5 if positive else inner + 0.5
            found.append(EdgeObservation(i, positive, inner, edge, edge - table_edge, share,
                                         step))
    return found


def readable_edges(spikes: Sequence[EdgeObservation], profile: Profile
                   ) -> list[EdgeObservation]:
    """The spikes whose edges can be read (module docstring): those of thrusters with a
    spike on both sides, and every spike of a thruster that carries the vehicle's weight
    (its thrust at least :data:`LIFTING` vertical)."""
    sides: dict[int, int] = {}
    for o in spikes:
        sides[o.thruster] = sides.get(o.thruster, 0) + 1
    lifting = np.abs(thrust_configuration(profile.thrusters)[2]) >= LIFTING
    return [o for o in spikes if sides[o.thruster] == 2 or lifting[o.thruster]]


def _spike(column: FloatArray, positive: bool, table_edge: float, neutral_us: float,
           reach_us: float) -> tuple[float, float] | None:
    """The hunting spike of one thruster's whole-µs outputs ``column`` on one side of
    neutral (module docstring): (the spike's PWM [µs], its share of the samples), or
    None."""
    side = column[column > neutral_us] if positive else column[column < neutral_us]
    if not len(side):
        return None
    inner = float(side.min() if positive else side.max())
    count = np.count_nonzero(side == inner)
    beside = np.count_nonzero(side == inner + (1 if positive else -1))
    if (abs(inner - table_edge) <= reach_us and count >= SPIKE_SHARE * len(column)
            and count >= SPIKE_RATIO * beside):
        return inner, count / len(column)
    return None


def hunting_factors(observations: Sequence[EdgeObservation], rows: NDArray[np.bool_],
                    profile: Profile) -> FloatArray:
    """How one hold's mean τ on ``rows`` moves with 1σ of what its hunting samples
    delivered, shape (rows, n) [N, N·m]: per thruster the spikes' share × step/√12 (the
    thrust of each hunting sample anywhere between zero and the step, uniform; one value
    for the whole hold, whatever balanced it, so it does not average out), in quadrature
    over the thruster's two edges. Independent between holds."""
    std = np.zeros(len(profile.thrusters))
    for o in observations:
        std[o.thruster] = math.hypot(std[o.thruster], o.share * o.step_N / math.sqrt(12))
    factors: FloatArray = thrust_configuration(profile.thrusters)[rows] * std
    return factors


def observed_bands(known: ThrustMapPosterior | None, observations: Sequence[EdgeObservation],
                   profile: Profile) -> ThrustMapPosterior | None:
    """``known`` (None: the profile's prior) conditioned on the edges ``observations``
    show, each edge once (the same edge seen by several holds: the mean of their
    offsets, ± :data:`EDGE_STD_US` or their spread, the larger, for a quantised reading
    does not average out) and only where ``known`` does not know it that well already
    (a calibration that read it, an earlier hold); ``known`` itself when there is none."""
    n = len(profile.thrusters)
    post = known or prior(profile)
    per_z = np.tile(error_scales(profile)[1], 4)     # µs per unit of z
    sigma_us = np.sqrt(np.diag(post.cov)) * per_z
    by_edge: dict[int, list[float]] = {}
    for o in observations:
        k = (3 if o.positive else 2) * n + o.thruster
        if sigma_us[k] > EDGE_STD_US:
            by_edge.setdefault(k, []).append(o.offset_us)
    if not by_edge:
        return known
    columns = sorted(by_edge)
    sigma_band = per_z[columns]
    offsets = [np.asarray(by_edge[k]) for k in columns]
    measured = np.array([v.mean() for v in offsets]) / sigma_band
    std = np.array([max(EDGE_STD_US, float(np.ptp(v)) / 2) for v in offsets]) / sigma_band
    P, mu = post.cov, post.mean
    S = P[np.ix_(columns, columns)] + np.diag(std**2)
    K = np.linalg.solve(S, P[columns]).T           # P·Hᵀ·S⁻¹ (S symmetric)
    mean = mu + K @ (measured - mu[columns])
    cov = P - K @ P[columns]
    return posterior(mean, cov, post.experiments)

