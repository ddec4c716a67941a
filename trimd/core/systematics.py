"""The systematic errors every hold of a static estimate shares, as the estimate carries
them (docs/method.md §3): the thrust map (each curve's gain error, each ESC's dead-band
offset), the attitude reference's slow error and the drift model of a vehicle that does
not hold station; and, for people, which rows and quantities rest on the dead band.

Each is given as *factors*: how a hold's mean τ on the rows used moves with one standard
deviation of each error [N, N·m]; :func:`trimd.core.estimate.estimate_static` puts them
into the weights and the sandwich covariance.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trimd.core.curve_error import BAND_SIGMA_SHARE, error_scales, thrusters_with_errors
from trimd.core.drift import munk_moment
from trimd.core.errors import EstimationError
from trimd.core.hunting import EdgeObservation, hunting_factors
from trimd.core.longrun import MeanCovariance
from trimd.core.model import (
    band_offset_sensitivity,
    restoring_matrix_jacobian,
    thrust_configuration,
    thrusts_from_pwm,
)
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

if TYPE_CHECKING:
    from trimd.core.estimate import HoldSamples

__all__ = [
    "BAND_SIGMA_SHARE",
    "attitude_error_factors",
    "band_notes",
    "drift_moments",
    "exposure_factors",
    "hold_error_cov",
    "thrust_exposure",
    "thrust_map_bias",
    "thrust_map_factors",
    "thrust_map_std",
]

_TAU_NAMES = ("X", "Y", "Z", "K", "M", "N")


def thrust_exposure(hold: HoldSamples, profile: Profile) -> FloatArray:
    """What of the thrust map's systematic errors a hold is exposed to, shape (4·n,): each
    thruster's mean forward thrust f̄⁺ [N], its mean reverse thrust f̄⁻ [N], then the mean
    sensitivity of its thrust to its dead band's negative and positive edge offset, per 1σ
    of the offset (:func:`trimd.core.model.band_offset_sensitivity` ×
    :data:`BAND_SIGMA_SHARE`) [N]. Zero for a hold without per-thruster thrust."""
    n = len(profile.thrusters)
    if hold.thrust is None:
        return np.zeros(4 * n)
    f = np.asarray(hold.thrust, float)
    if f.shape != (len(hold.phi), n) or not np.all(np.isfinite(f)):
        raise EstimationError(
            f"hold {hold.label!r}: per-thruster thrust of shape {f.shape} (finite values, "
            f"one row per sample and one column per thruster: ({len(hold.phi)}, "
            f"{n}) expected)")
    forward, reverse = np.maximum(f, 0).mean(axis=0), np.minimum(f, 0).mean(axis=0)
    negative, positive = band_offset_sensitivity(profile, f).mean(axis=1) * BAND_SIGMA_SHARE
    exposure: FloatArray = np.concatenate([forward, reverse, negative, positive])
    return exposure


def exposure_factors(exposure: FloatArray, rows: NDArray[np.bool_], profile: Profile
                     ) -> FloatArray:
    """How a hold's mean τ on ``rows`` moves with 1σ of each systematic error of the
    *profile's* thrust map (its prior: the curves' ``uncertainty_pct``, the dead-band
    margins), shape (rows, 4·n) [N, N·m]: T_rows·diag(exposure·[σ_gain, σ_gain, 1, 1]),
    ``exposure`` from :func:`thrust_exposure`."""
    T = thrust_configuration(profile.thrusters) if profile.thrusters else np.zeros((6, 0))
    sigma = error_scales(profile)[0]
    forward, reverse, negative, positive = np.split(exposure, 4)
    factors: FloatArray = np.concatenate([T[rows] * (forward * sigma),
                                          T[rows] * (reverse * sigma),
                                          T[rows] * negative, T[rows] * positive], axis=1)
    return factors


def thrust_map_factors(holds: Sequence[HoldSamples], used: Sequence[NDArray[np.bool_]],
                       profile: Profile) -> list[FloatArray]:
    """Per hold, how its mean τ (the rows used) moves with each systematic error of the
    thrust map, one column per error, shape (rows, 4·n) [N, N·m per 1σ]: each thruster's
    relative gain error forward, then reverse (T_rows·diag(f̄±)·diag(σ_gain)), then the
    offset of its dead band's (its ESC's) negative edge, then its positive edge
    (T_rows·diag(s̄±)·:data:`BAND_SIGMA_SHARE`, s̄ the hold's mean
    :func:`trimd.core.model.band_offset_sensitivity`). The same column is the same error
    in every hold. Zero for a hold without per-thruster thrust.

    With a calibration (the profile's ``thrust_map``, :mod:`trimd.core.calibration`) the
    errors left are the posterior's: the factors are the prior's times the posterior
    covariance's lower Cholesky factor L (in units of the prior σ), F·L, so that F·L·Lᵀ·Fᵀ
    is the covariance the calibration supports; its mean is :func:`thrust_map_bias`."""
    n = len(profile.thrusters)
    raw = [exposure_factors(thrust_exposure(h, profile), r, profile) if h.thrust is not None
           else np.zeros((int(r.sum()), 4 * n)) for h, r in zip(holds, used, strict=True)]
    if profile.thrust_map is None:
        return raw
    return [F @ profile.thrust_map.sqrt_cov for F in raw]


def thrust_map_bias(holds: Sequence[HoldSamples], used: Sequence[NDArray[np.bool_]],
                    profile: Profile) -> list[FloatArray]:
    """Per hold, what the calibration (the profile's ``thrust_map``) adds to its mean τ on
    the rows used [N, N·m] (the true thrust is the profile map's plus this); zero without
    one. A hold that kept its outputs reads them again through the curves with the
    posterior mean μ of the errors (:func:`trimd.core.curve_error.thrusters_with_errors`);
    one that did not moves by F·μ, F its prior factors."""
    post = profile.thrust_map
    if post is None:
        return [np.zeros(int(r.sum())) for r in used]
    T = thrust_configuration(profile.thrusters)
    fitted = dataclasses.replace(profile, thrusters=thrusters_with_errors(profile, post.mean))
    out = []
    for h, r in zip(holds, used, strict=True):
        if h.outputs is None or h.thrust is None:
            out.append(exposure_factors(thrust_exposure(h, profile), r, profile) @ post.mean)
        else:
            f = thrusts_from_pwm(fitted, h.outputs.pwm_us, h.outputs.voltage_V) - h.thrust
            out.append(T[r] @ f.mean(axis=0))
    return out


def thrust_map_std(hold: HoldSamples, rows: NDArray[np.bool_], profile: Profile
                   ) -> FloatArray:
    """1σ of the hold's mean τ on ``rows`` [N, N·m] from the thrust map's systematic errors
    alone (the curves' ``uncertainty_pct`` and the dead-band edges): the part of its ± that
    no length of collecting reduces. Zero for a hold without per-thruster thrust."""
    factors = thrust_map_factors([hold], [rows], profile)[0]
    std: FloatArray = np.sqrt((factors**2).sum(axis=1))
    return std


def attitude_error_factors(attitude: Sequence[tuple[float, float]],
                           used: Sequence[NDArray[np.bool_]], profile: Profile,
                           q: FloatArray) -> list[FloatArray]:
    """Per hold, how its mean τ (the rows used) moves with a 1σ error of the attitude
    reference in roll and in pitch (the profile's ``attitude_error_deg``), shape
    (rows, 2) [N, N·m]: ∂G/∂(φ, θ)·q·σ. Independent between holds, and not reduced by
    collecting (an AHRS wanders over tens of seconds, longer than a hold)."""
    sigma = math.radians(profile.attitude_error_deg)
    out = []
    for (phi, theta), r in zip(attitude, used, strict=True):
        dG = restoring_matrix_jacobian(phi, theta)  # (6, 4, 2)
        out.append(np.einsum("ijk,j->ik", dG, q)[r] * sigma)
    return out



def hold_error_cov(phi_rad: float, theta_rad: float, rows: NDArray[np.bool_],
                   profile: Profile, q: FloatArray,
                   spikes: Sequence[EdgeObservation] = ()) -> FloatArray:
    """The covariance one hold adds to a comparison of its mean τ on ``rows`` [N², N·m
    squared]: its attitude reference's error at roll ``phi_rad``, pitch ``theta_rad``
    [rad] with the vehicle's ``q`` (:func:`attitude_error_factors`) and what its hunting
    ``spikes`` delivered (:func:`~trimd.core.hunting.hunting_factors`)."""
    E = attitude_error_factors([(phi_rad, theta_rad)], [rows], profile, q)[0]
    cov: FloatArray = E @ E.T
    if spikes:
        U = hunting_factors(spikes, rows, profile)
        cov = cov + U @ U.T
    return cov

def drift_moments(attitude: Sequence[tuple[float, float]],
                   used: Sequence[NDArray[np.bool_]], profile: Profile,
                   net_weight_N: float) -> list[FloatArray]:
    """Per hold, the Munk moment of its drift on the rows used [N·m; 0 on force rows];
    all zero when the vehicle holds station. An axis without damping has no steady drift
    to model: no correction there."""
    out = []
    for (phi, theta), r in zip(attitude, used, strict=True):
        row = np.zeros(6)
        if not profile.holds_station:
            m = munk_moment(profile, phi, theta, net_weight_N)
            row[3:] = np.where(np.isfinite(m), m, 0.0)
        out.append(row[r])
    return out


def band_notes(holds: Sequence[HoldSamples], used: Sequence[NDArray[np.bool_]],
               factors: Sequence[FloatArray], means: Sequence[MeanCovariance],
               q: FloatArray, q_cov: FloatArray, q_cov_band: FloatArray) -> tuple[str, ...]:
    """For people: each row of a hold whose variance is mostly its thrusters' dead band
    (it was down-weighted: "hold 2, N row: 4 thrusters at or near the dead-band edge"),
    and how much of the passive roll's and pitch's variance rests on the band when that
    is most of it. ``factors`` from :func:`thrust_map_factors`."""
    notes = []
    for h, r, f, m in zip(holds, used, factors, means, strict=True):
        n = f.shape[1] // 4
        band = f[:, 2 * n:]
        noise = np.diag(m.interval_cov)
        share = (band**2).sum(axis=1) / (noise + (f**2).sum(axis=1) + 1e-300)
        for row, s, b in zip(np.flatnonzero(r), share, band, strict=True):
            if s > 0.5:
                c = b[:n]**2 + b[n:]**2  # each thruster's share of the row's band variance
                count = int(np.sum(c > 0.1 * c.sum()))
                notes.append(f"{h.label or 'hold'}, {_TAU_NAMES[row]} row: {count} thruster"
                             f"{'s' if count != 1 else ''} at or near the dead-band edge "
                             f"({100 * s:.0f} % of its variance; down-weighted)")
    k = float(q[3])
    if k > 0:
        for name, i in (("roll", 2), ("pitch", 1)):
            share = q_cov_band[i, i] / q_cov[i, i] if q_cov[i, i] > 0 else 0.0
            if share > 0.5:
                notes.append(f"passive {name} ± {math.degrees(math.sqrt(q_cov[i, i]) / k):.2f}°"
                             f" (1σ): {100 * share:.0f} % of its variance from thrusters at or "
                             "near their dead band (the ESC offsets the profile's "
                             "deadband_margin_us allows); a verify hold after ballasting "
                             "measures what is left")
    return tuple(notes)
