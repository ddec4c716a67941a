"""A simulated vehicle that differs from its profile, and its passive trim.

The simulator flies a *true* profile: the nominal one with its buoyancy, centre of
buoyancy and thrust curves off by the amounts of ``SimConfig.buoyancy_err``,
``cob_err_mm`` and ``thrust_err`` (each thrust error's size drawn in [thrust_err,
thrust_err_max] when that is larger), in directions drawn from the seed. Everything that
reads the profile — trimd, and the simulated autopilot's mixer and controller — sees the
nominal one, as on a real vehicle whose profile was measured or computed imperfectly.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trimd.core.curve_error import curve_with_errors, error_scales
from trimd.core.profile import Profile, ThrustCurve, Thruster
from trimd.drivers.sim.config import SimConfig

__all__ = ["TruthOffset", "implied_mass", "passive_trim_deg", "perturb_profile",
           "thrust_map_errors", "true_thrusters"]

#: Random stream of the perturbation (beside the noise and disturbance streams).
_STREAM = 100
#: Random stream of the curves' shape errors (``SimConfig.thrust_shape_err``).
_SHAPE_STREAM = 102
#: Random stream of the thrust errors' sizes (``SimConfig.thrust_err_max``), apart from
#: :data:`_STREAM` so that setting it leaves every other draw of a seed as it was.
_THRUST_SIZE_STREAM = 101


@dataclass(frozen=True, slots=True)
class TruthOffset:
    """How the true vehicle differs from its profile (all zero: not at all).

    Attributes
    ----------
    buoyancy_factor : true B / profile B.
    r_b_offset_m : true r_b − profile r_b [m] (body FRD).
    thrust_factors : per thruster (profile order), true / profile thrust for a forward
        (PWM above neutral) and a reverse output.
    band_offsets_us : per thruster, true − profile dead-band edge (low, high) [µs]; empty
        when the bands are the profile's.
    shape_errors : per thruster, the curve's shape error s forward and reverse
        (``SimConfig.thrust_shape_err``); empty when there is none.
    """

    buoyancy_factor: float
    r_b_offset_m: tuple[float, float, float]
    thrust_factors: tuple[tuple[float, float], ...]
    band_offsets_us: tuple[tuple[float, float], ...] = ()
    shape_errors: tuple[tuple[float, float], ...] = ()


def perturb_profile(profile: Profile, config: SimConfig) -> tuple[Profile, TruthOffset]:
    """The true profile of the vehicle ``config`` describes, and how it differs.

    Signs (buoyancy, each thruster direction) are ±1 with equal chance and the centre of
    buoyancy moves in a direction uniform on the sphere, all drawn from ``config.truth_seed``
    (``config.seed`` when it is −1);
    the sizes are exactly those of ``config`` (a thrust error's size uniform in
    [thrust_err, thrust_err_max] when ``thrust_err_max`` is larger). With no error
    configured the true profile is ``profile`` itself.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("bluerov2-heavy")
    >>> true, err = perturb_profile(p, SimConfig(seed=1, buoyancy_err=0.01, cob_err_mm=5))
    >>> round(abs(true.buoyancy_N / p.buoyancy_N - 1), 6), round(1000 * float(np.linalg.norm(
    ...     np.subtract(true.r_b_m, p.r_b_m))), 6)
    (0.01, 5.0)
    """
    if not (config.buoyancy_err or config.cob_err_mm or config.thrust_err
            or config.thrust_err_max or config.esc_band_us or config.thrust_shape_err):
        n = len(profile.thrusters)
        return profile, TruthOffset(1.0, (0.0, 0.0, 0.0), ((1.0, 1.0),) * n)
    rng = np.random.default_rng([_truth_seed(config), _STREAM])
    sign_b = float(rng.choice((-1.0, 1.0)))
    direction = rng.standard_normal(3)
    direction /= np.linalg.norm(direction)
    signs = rng.choice((-1.0, 1.0), size=(len(profile.thrusters), 2))
    dx, dy, dz = (float(v) for v in 1e-3 * config.cob_err_mm * direction)
    k = _thrust_err_sizes(config, len(profile.thrusters))
    band = config.esc_band_us * rng.uniform(-1.0, 1.0, size=(len(profile.thrusters), 2))
    error = TruthOffset(buoyancy_factor=1.0 + sign_b * config.buoyancy_err,
                        r_b_offset_m=(dx, dy, dz),
                        thrust_factors=tuple((1.0 + float(kf * f), 1.0 + float(kr * r))
                                             for (f, r), (kf, kr) in zip(signs, k,
                                                                         strict=True)),
                        band_offsets_us=tuple((float(lo), float(hi)) for lo, hi in band)
                        if config.esc_band_us else (),
                        shape_errors=_shape_errors(config, len(profile.thrusters)))
    x_b, y_b, z_b = profile.r_b_m
    r_b = (x_b + dx, y_b + dy, z_b + dz)
    true = dataclasses.replace(profile, buoyancy_N=profile.buoyancy_N * error.buoyancy_factor,
                               r_b_m=r_b, thrusters=true_thrusters(profile, error))
    return true, error


def true_thrusters(profile: Profile, offset: TruthOffset, *, gains: bool = True,
                   bands: bool = True) -> tuple[Thruster, ...]:
    """The thrusters of ``profile`` with their true curves: each scaled by its
    ``offset.thrust_factors`` (``gains``) and its dead band moved by its
    ``offset.band_offsets_us`` (``bands``; :func:`trimd.core.curve_error.curve_with_errors`).
    With both: what the simulator flies; with one, a thrust map known in part
    (``bench/bench_thrust_map_ceiling.py``)."""
    n = len(profile.thrusters)
    factors = offset.thrust_factors if gains else ((1.0, 1.0),) * n
    moved = offset.band_offsets_us if bands and offset.band_offsets_us else ((0.0, 0.0),) * n
    shapes = offset.shape_errors if gains and offset.shape_errors else ((0.0, 0.0),) * n
    return tuple(dataclasses.replace(t, curve=curve_with_errors(_shaped(t.curve, *s), f, b))
                 for t, f, b, s in zip(profile.thrusters, factors, moved, shapes, strict=True))


def thrust_map_errors(profile: Profile, offset: TruthOffset) -> NDArray[np.float64]:
    """The true thrust map's errors in a calibration's units (:mod:`trimd.core.curve_error`):
    z, shape (4·n,), gains forward, gains reverse, band edges negative, positive, each in
    units of the profile's prior 1σ, so that ``thrusters_with_errors(profile, z)`` is what
    the simulator flies (less any ``shape_errors``, which no z describes).

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("bluerov2-heavy")
    >>> n = len(p.thrusters)
    >>> z = thrust_map_errors(p, TruthOffset(1.0, (0.0, 0.0, 0.0), ((1.05, 1.0),) * n,
    ...                                      ((0.0, -5.0 / math.sqrt(3)),) * n))
    >>> [round(float(v), 6) for v in (z[0], z[n], z[2 * n], z[3 * n])]
    [1.0, 0.0, 0.0, -1.0]
    """
    n = len(profile.thrusters)
    gains = np.array(offset.thrust_factors, float) - 1.0
    bands = np.array(offset.band_offsets_us, float) if offset.band_offsets_us else np.zeros(
        (n, 2))
    s_gain, s_band = error_scales(profile)
    z: NDArray[np.float64] = np.r_[gains[:, 0] / s_gain, gains[:, 1] / s_gain,
                                   bands[:, 0] / s_band, bands[:, 1] / s_band]
    return z


def _shaped(curve: ThrustCurve, forward: float, reverse: float) -> ThrustCurve:
    """``curve`` with each table's thrusts f × (1 + s·(1 − 2·|f|/f_max)), s ``forward`` for
    positive and ``reverse`` for negative thrusts, f_max the table's largest that way."""
    if not (forward or reverse):
        return curve
    tables = []
    for table in curve.tables:
        top = {True: max(table.thrust_N), False: -min(table.thrust_N)}
        s = {True: forward, False: reverse}
        tables.append(dataclasses.replace(table, thrust_N=tuple(
            f * (1 + s[f > 0] * (1 - 2 * abs(f) / top[f > 0])) if top[f > 0] > 0 else f
            for f in table.thrust_N)))
    return dataclasses.replace(curve, tables=tuple(tables))


def _shape_errors(config: SimConfig, n: int) -> tuple[tuple[float, float], ...]:
    """Each of ``n`` thrusters' shape error s forward and reverse (module docstring of
    ``SimConfig.thrust_shape_err``), from a stream of its own; empty without one."""
    if not config.thrust_shape_err:
        return ()
    rng = np.random.default_rng([_truth_seed(config), _SHAPE_STREAM])
    signs = rng.choice((-1.0, 1.0), size=(n, 2))
    return tuple((float(f), float(r)) for f, r in config.thrust_shape_err * signs)


def _truth_seed(config: SimConfig) -> int:
    """The seed of the vehicle's errors: ``truth_seed``, or ``seed`` when that is −1."""
    return config.seed if config.truth_seed < 0 else config.truth_seed


def _thrust_err_sizes(config: SimConfig, n: int) -> NDArray[np.float64]:
    """Size [fraction] of the thrust error of each of ``n`` thrusters (rows) forward and
    reverse (columns): ``thrust_err``, or uniform in [thrust_err, thrust_err_max] from a
    stream of its own when ``thrust_err_max`` is larger."""
    k = config.thrust_err
    if config.thrust_err_max <= k:
        return np.full((n, 2), k)
    rng = np.random.default_rng([_truth_seed(config), _THRUST_SIZE_STREAM])
    return rng.uniform(k, config.thrust_err_max, size=(n, 2))


def passive_trim_deg(net: ArrayLike) -> tuple[float, float]:
    """Roll and pitch [deg] at which the restoring forces of q = [W − B, W·r_g − B·r_b]
    [N, N·m] have no moment: where the vehicle floats with thrusters off (Fossen eq. 4.6:
    the moment vanishes when W·r_g − B·r_b points along gravity in the body frame,
    below the origin).

    Examples
    --------
    >>> [round(a, 3) for a in passive_trim_deg([0.0, -0.1, 0.05, 1.0])]
    [2.862, 5.704]
    """
    _, nx, ny, nz = (float(v) for v in np.asarray(net, float))
    return (math.degrees(math.atan2(ny, nz)), math.degrees(math.atan2(-nx, math.hypot(ny, nz))))


def implied_mass(profile: Profile, net: ArrayLike) -> tuple[float, NDArray[np.float64]]:
    """m_ext [kg] and r_g [m] (body FRD, origin CG0) that q = [W − B, W·r_g − B·r_b]
    [N, N·m] implies through the *profile's* B and r_b: what an exact estimate of q
    reports. On a vehicle that differs from its profile these are the numbers to compare
    an estimate's m_ext and r_g with (the hidden payload's mass is not identifiable then:
    1 % of B is 0.14 kg on the BlueROV2 Heavy, 11.9 kg on the Sabertooth).

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> from trimd.drivers.sim.payload import mass_properties, parse_payload
    >>> p = load_profile("sabertooth-dh2")
    >>> m_ext, r_g = implied_mass(p, mass_properties(p, parse_payload("10@AftSB", p)).net)
    >>> round(m_ext, 9), [round(float(v), 4) for v in r_g]
    (10.0, [-0.0086, 0.005, 0.0])
    """
    q = np.asarray(net, float)
    B = profile.buoyancy_N
    W = float(q[0]) + B
    return W / profile.gravity_m_s2 - profile.mass_kg, (q[1:] + B * np.asarray(profile.r_b_m)) / W
