"""A thrust curve with the errors the thrust map models (docs/method.md §3, §7): its
forward and reverse thrusts scaled (a gain error per direction) and its ESC's dead band
moved (an offset per edge). The simulator flies such curves as its truth
(:mod:`trimd.drivers.sim.truth`); a calibration fits them
(:mod:`trimd.core.thrust_fit`).

The errors of a profile's n thrusters in units of their prior 1σ, z, shape (4·n,), are in
:mod:`trimd.core.systematics`' order: gains forward, gains reverse, band edges negative,
positive. A gain's 1σ is the curve's ``uncertainty_pct``; an edge offset's is
:data:`BAND_SIGMA_SHARE` × its ``deadband_margin_us``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike

from trimd.core.profile import Profile, ThrustCurve, Thruster
from trimd.core.types import FloatArray

__all__ = ["BAND_SIGMA_SHARE", "curve_with_errors", "error_scales", "offset_band",
           "scaled_curve", "thrusters_with_errors"]

#: 1σ of an ESC's dead-band offset as a share of the curve's ``deadband_margin_us``: the
#: offset anywhere within ± the margin (uniform: 1/√3).
BAND_SIGMA_SHARE = 1 / math.sqrt(3)


def scaled_curve(curve: ThrustCurve, forward: float, reverse: float) -> ThrustCurve:
    """``curve`` with its positive thrusts × ``forward`` and negative ones × ``reverse``
    (the dead band and PWM range unchanged)."""
    if forward == 1.0 and reverse == 1.0:
        return curve
    return dataclasses.replace(curve, tables=tuple(
        dataclasses.replace(table, thrust_N=tuple(f * (forward if f > 0 else reverse)
                                                  for f in table.thrust_N))
        for table in curve.tables))


def offset_band(curve: ThrustCurve, low_us: float, high_us: float) -> ThrustCurve:
    """``curve`` as an ESC whose zero band is offset: every table point below neutral and
    the band's low edge move by ``low_us``, every point above neutral and the high edge by
    ``high_us`` [µs] (positive: later in PWM). Near the band the thrust of one PWM then
    differs by up to the edge thrust, further out by the curve's slope times the offset."""
    if not (low_us or high_us):
        return curve
    neutral = curve.neutral_us
    tables = []
    for table in curve.tables:
        lo, hi = table.deadband_us
        tables.append(dataclasses.replace(
            table, deadband_us=(lo + low_us, hi + high_us),
            pwm_us=tuple(p + (high_us if p > neutral else low_us) for p in table.pwm_us)))
    return dataclasses.replace(curve, tables=tuple(tables))


def curve_with_errors(curve: ThrustCurve, gains: tuple[float, float],
                      band_us: tuple[float, float]) -> ThrustCurve:
    """``curve`` scaled by the factors ``gains`` (forward, reverse; 1: none), then its band
    edges moved by ``band_us`` (negative edge, positive edge) [µs]."""
    return offset_band(scaled_curve(curve, *gains), *band_us)


def error_scales(profile: Profile) -> tuple[FloatArray, FloatArray]:
    """Per thruster (the profile's order) the prior 1σ of a gain error [fraction] and of a
    band edge's offset [µs]: what one unit of z is (module docstring)."""
    curves = [t.curve for t in profile.thrusters]
    return (np.array([c.uncertainty_pct / 100 for c in curves]),
            np.array([c.deadband_margin_us * BAND_SIGMA_SHARE for c in curves]))


def thrusters_with_errors(profile: Profile, z: ArrayLike) -> tuple[Thruster, ...]:
    """The profile's thrusters with the errors ``z`` [prior σ, module docstring] applied
    to their curves: gains 1 + σ_gain·z, band edges moved by σ_band·z [µs]."""
    forward, reverse, low, high = np.split(np.asarray(z, float), 4)
    s_gain, s_band = error_scales(profile)
    out = []
    for i, t in enumerate(profile.thrusters):
        curve = curve_with_errors(t.curve, (1 + s_gain[i] * float(forward[i]),
                                            1 + s_gain[i] * float(reverse[i])),
                                  (s_band[i] * float(low[i]), s_band[i] * float(high[i])))
        out.append(t if curve is t.curve else dataclasses.replace(t, curve=curve))
    return tuple(out)
