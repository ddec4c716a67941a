"""Thruster effort τ at given times: the latest thruster outputs (and battery voltage) held
onto each time by zero-order hold (:func:`trimd.core.resample.zoh_align`), through the
profile's thrust curves and geometry (:func:`trimd.core.model.tau_from_pwm`).

One function for every consumer: the replay of foreign logs and identification; the live
procedure holds the latest outputs the same way, one sample at a time
(:class:`HeldThrust`), with the same age limit :data:`MAX_THRUSTER_AGE_S`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trimd.core.errors import DataError
from trimd.core.estimate import HeldOutputs
from trimd.core.model import thrust_configuration, thrusts_from_pwm
from trimd.core.profile import Profile
from trimd.core.resample import zoh_align
from trimd.core.samples import Battery, Thrusters

__all__ = ["MAX_THRUSTER_AGE_S", "HeldThrust", "outputs_at", "tau_at", "thrust_at"]

#: Thruster outputs older than this [s] are not held onto a later time: a gap, not a value.
#: ArduSub streams SERVO_OUTPUT_RAW at 2–10 Hz; a ground station may leave 1 Hz.
MAX_THRUSTER_AGE_S = 1.0


def outputs_at(profile: Profile, t_s: ArrayLike, thrusters: Sequence[Thrusters],
               batteries: Sequence[Battery] = (), *, max_age_s: float = MAX_THRUSTER_AGE_S
               ) -> tuple[HeldOutputs, NDArray[np.bool_]]:
    """The thruster outputs [µs] and battery voltage [V] held onto the times ``t_s`` [s]
    (zero-order hold), and where they are valid.

    Rows without thruster outputs at most ``max_age_s`` old are NaN and not valid. The
    battery voltage is held the same way (no age limit); without it, or where it is not a
    positive number, the profile's nominal voltage is used. DataError when a thruster
    sample does not have one output per thruster of the profile.
    """
    t = np.asarray(t_s, float)
    n_thr = len(profile.thrusters)
    bad = {len(s.pwm_us) for s in thrusters} - {n_thr}
    if bad:
        raise DataError(f"thruster samples with {sorted(bad)} outputs for a profile with "
                        f"{n_thr} thrusters")
    if not thrusters:
        return (HeldOutputs(np.full((len(t), n_thr), np.nan), np.full(len(t), np.nan)),
                np.zeros(len(t), bool))
    pwm = zoh_align(t, [s.t_s for s in thrusters], [s.pwm_us for s in thrusters],
                    max_age_s=max_age_s)
    volts = (zoh_align(t, [b.t_s for b in batteries], [b.voltage_V for b in batteries]).values
             if batteries else np.full(len(t), np.nan))
    volts = np.where(np.isfinite(volts) & (volts > 0), volts, profile.nominal_voltage_V)
    return HeldOutputs(pwm.values.reshape(len(t), n_thr), volts), pwm.valid


def thrust_at(profile: Profile, t_s: ArrayLike, thrusters: Sequence[Thrusters],
              batteries: Sequence[Battery] = (), *, max_age_s: float = MAX_THRUSTER_AGE_S
              ) -> tuple[NDArray[np.float64], NDArray[np.bool_], HeldOutputs]:
    """Each thruster's thrust [N] (along its positive direction, the profile's thruster
    order) at the times ``t_s`` [s], where it is valid, and the outputs it was read from
    (:func:`outputs_at`, whose rules it follows)."""
    outputs, ok = outputs_at(profile, t_s, thrusters, batteries, max_age_s=max_age_s)
    thrust = np.full(outputs.pwm_us.shape, np.nan)
    thrust[ok] = thrusts_from_pwm(profile, outputs.pwm_us[ok], outputs.voltage_V[ok])
    return thrust, ok, outputs


def tau_at(profile: Profile, t_s: ArrayLike, thrusters: Sequence[Thrusters],
           batteries: Sequence[Battery] = (), *, max_age_s: float = MAX_THRUSTER_AGE_S
           ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """τ [N, N·m] (body FRD, about CG0) at the times ``t_s`` [s], and where it is valid:
    :func:`thrust_at` through the thrust configuration.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("bluerov2-heavy")
    >>> neutral = Thrusters(0.0, tuple(1500.0 for _ in p.thrusters))
    >>> tau, valid = tau_at(p, [0.5, 2.0], [neutral])
    >>> valid.tolist(), tau[0].tolist() == [0.0] * 6
    ([True, False], True)
    """
    thrust, ok, _ = thrust_at(profile, t_s, thrusters, batteries, max_age_s=max_age_s)
    tau = np.full((len(ok), 6), np.nan)
    if profile.thrusters:
        tau[ok] = thrust[ok] @ thrust_configuration(profile.thrusters).T
    else:
        tau[ok] = 0.0
    return tau, ok


class HeldThrust:
    """The latest thruster outputs and battery voltage, held onto later times one sample
    at a time (the live procedure's zero-order hold): each thruster's thrust and τ."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        #: the thrust configuration matrix T: τ = T·f
        self.T = thrust_configuration(profile.thrusters)
        self.voltage_V = profile.nominal_voltage_V
        self.outputs: Thrusters | None = None

    def battery(self, s: Battery) -> None:
        """A battery sample: its voltage from now on (a non-positive or NaN one is not)."""
        if np.isfinite(s.voltage_V) and s.voltage_V > 0:
            self.voltage_V = s.voltage_V

    def thrust(self, t_s: float) -> NDArray[np.float64] | None:
        """Each thruster's thrust [N] from the latest outputs held onto ``t_s`` (None when
        there are none within :data:`MAX_THRUSTER_AGE_S` before it); ValueError when the
        outputs do not match the profile's thrusters."""
        p = self.outputs
        if p is None or not 0 <= t_s - p.t_s <= MAX_THRUSTER_AGE_S:
            return None
        if len(p.pwm_us) != len(self.profile.thrusters):
            raise ValueError(f"{len(p.pwm_us)} thruster outputs for "
                             f"{len(self.profile.thrusters)} thrusters in the profile")
        thrust: NDArray[np.float64] = thrusts_from_pwm(self.profile, p.pwm_us, self.voltage_V)
        return thrust

    def tau(self, t_s: float) -> NDArray[np.float64] | None:
        """τ [N, N·m] from the latest outputs held onto ``t_s`` (None as :meth:`thrust`)."""
        thrust = self.thrust(t_s)
        return None if thrust is None else self.T @ thrust
