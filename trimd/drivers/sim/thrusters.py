"""Thrusters of the simulated vehicle: mixing of axis demands to outputs, PWM, spin-up, thrust.

Outputs are normalised per thruster to [−1, 1] and become integer PWM as ArduSub does:
``PWM = neutral + out·(max − neutral)`` for out > 0, else ``neutral + out·(neutral − min)``,
flipped about neutral for a reversed thruster (MOT_n_DIRECTION = −1), neutral when
disarmed. The physical thrust follows the profile's thrust curve at the battery voltage
(deadband included: a small output can give no thrust at all) through a first-order
spin-up lag, and τ = T·f (Fossen eq. 11.3). With ``hunt`` (``SimConfig.esc_hunt``) an
output inside a thruster's true dead band hunts at the band edge: the thruster reports the
first PWM out of the band on the output's side and delivers, averaged over the hunting,
thrust rising linearly from 0 at neutral to that PWM's thrust (what an autopilot's
integrator settles on: whatever balances). The reported PWM then reads, through the
profile's curve, a thrust that can be off by the whole edge thrust (docs/method.md §3,
"The thrust map near the dead band").

Mixing of the six axis inputs (X, Y, Z, K, M, N order, each in [−1, 1]):

* ArduSub FRAME_CONFIG 2 (BlueROV2 Heavy, 8 thrusters): the AP_Motors6DOF factor table
  (``docs/ardusub.md``); the vertical group (roll, pitch, throttle) and the
  horizontal group (yaw, forward, lateral) are each scaled down together when one of
  their outputs exceeds 1;
* any other vehicle: least squares, outputs = pinv(T·diag(k))·τ, each axis scaled to the
  largest τ it can reach, all outputs scaled down together on saturation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from operator import mul

import numpy as np

from trimd.core.model import thrust_configuration, thrust_from_pwm
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

__all__ = ["ARDUSUB_HEAVY_FACTORS", "Mixer", "ThrusterBank"]


#: AP_Motors6DOF factors of FRAME_CONFIG 2 per motor 1..8:
#: roll, pitch, yaw, throttle, forward, lateral.
ARDUSUB_HEAVY_FACTORS: tuple[tuple[float, ...], ...] = (
    (0, 0, 1, 0, -1, 1), (0, 0, -1, 0, -1, -1), (0, 0, -1, 0, 1, 1), (0, 0, 1, 0, 1, -1),
    (1, -1, 0, -1, 0, 0), (-1, -1, 0, -1, 0, 0), (1, 1, 0, -1, 0, 0), (-1, 1, 0, -1, 0, 0),
)


def _pwm_range(profile: Profile, i: int) -> tuple[int, int, float]:
    """(min, max, neutral) PWM [µs] of thruster ``i``: its curve's table ends."""
    t = profile.thrusters[i]
    lo = min(min(tb.pwm_us) for tb in t.curve.tables)
    hi = max(max(tb.pwm_us) for tb in t.curve.tables)
    return math.ceil(lo), math.floor(hi), t.curve.neutral_us


def _true_band(table: Sequence[float], pwm_range: tuple[int, int, float]
               ) -> tuple[int, int, int]:
    """(first PWM below, first PWM above the zero-thrust band around neutral, neutral)
    [µs] of one thruster's thrust ``table`` (one value per integer PWM of ``pwm_range``)."""
    lo, hi, neutral_us = pwm_range
    neutral = round(neutral_us)
    below = above = neutral
    while below > lo and table[below - lo] == 0.0:
        below -= 1
    while above < hi and table[above - lo] == 0.0:
        above += 1
    return below, above, neutral


class Mixer:
    """Axis inputs → per-thruster outputs → integer PWM, for one profile.

    Attributes
    ----------
    matrix : outputs per unit axis input, n × 6 (X, Y, Z, K, M, N columns).
    tau_unit : τ [N, N·m] per unit axis input with a linear thruster of gain k (6,);
        the controller divides its demand by it.
    groups : thruster indices scaled together on saturation.
    """

    def __init__(self, profile: Profile, voltage_V: float) -> None:
        n = len(profile.thrusters)
        self.ranges = [_pwm_range(profile, i) for i in range(n)]
        self._sign = [-1.0 if t.reversed else 1.0 for t in profile.thrusters]
        T = thrust_configuration(profile.thrusters)
        k = np.array([0.5 * float(np.ptp(thrust_from_pwm(t.curve, r[:2], voltage_V)))
                      for t, r in zip(profile.thrusters, self.ranges, strict=True)])
        channels = sorted(t.channel for t in profile.thrusters)
        if profile.frame_config == 2 and channels == list(range(1, 9)):
            F = np.array([ARDUSUB_HEAVY_FACTORS[t.channel - 1] for t in profile.thrusters])
            # axis order X, Y, Z, K, M, N ← forward, lateral, −throttle, roll, pitch, yaw
            A = np.column_stack([F[:, 4], F[:, 5], -F[:, 3], F[:, 0], F[:, 1], F[:, 2]])
            A = A * np.asarray(self._sign)[:, None]   # firmware reverses a reversed motor
            vertical = [i for i in range(n) if np.any(F[i, [0, 1, 3]] != 0)]
            self.groups = [vertical, [i for i in range(n) if i not in vertical]]
            self.kind = "ardusub-frame-2"
        else:
            A = np.linalg.pinv(T * k)
            A = A / np.maximum(np.abs(A).max(axis=0), 1e-12)
            self.groups = [list(range(n))]
            self.kind = "least-squares"
        self.matrix: FloatArray = A
        self.tau_unit: FloatArray = np.diag(T @ (k[:, None] * A)).copy()
        if np.any(np.abs(self.tau_unit) < 1e-9):
            missing = [a for a, u in zip("XYZKMN", self.tau_unit, strict=True) if abs(u) < 1e-9]
            raise ValueError(f"{profile.name}: the thrusters cannot act on axes {missing}")
        self._rows = tuple(tuple(float(v) for v in row) for row in A)
        #: per thruster: direction sign, neutral PWM and PWM per unit output above / below
        #: neutral [µs]
        self._pwm_scale = tuple((sign, neutral, hi - neutral, neutral - lo)
                                for sign, (lo, hi, neutral) in zip(self._sign, self.ranges,
                                                                   strict=True))

    def outputs(self, axes: Sequence[float]) -> tuple[float, ...]:
        """Normalised outputs in [−1, 1] for axis inputs (X, Y, Z, K, M, N order)."""
        X, Y, Z, K, M, N = axes
        out = [a * X + b * Y + c * Z + d * K + e * M + f * N
               for a, b, c, d, e, f in self._rows]
        for group in self.groups:
            peak = max([abs(out[i]) for i in group])
            if peak > 1.0:
                for i in group:
                    out[i] /= peak
        return tuple(out)

    def pwm(self, outputs: Sequence[float], dither_us: Sequence[float] = ()
            ) -> tuple[int, ...]:
        """Integer PWM [µs] for normalised outputs (reversal applied, saturated), with
        ``dither_us`` [µs] per thruster added before rounding (kept within the range)."""
        result = []
        for out, (sign, neutral, up, down) in zip(outputs, self._pwm_scale, strict=True):
            o = sign * out
            if o > 0.0:
                result.append(neutral + (o if o < 1.0 else 1.0) * up)
            else:
                result.append(neutral + (o if o > -1.0 else -1.0) * down)
        if not dither_us:
            return tuple([round(p) for p in result])
        return tuple([round(min(max(p + d, neutral - down), neutral + up))
                      for p, d, (_, neutral, up, down) in zip(result, dither_us,
                                                               self._pwm_scale, strict=True)])

    def neutral(self) -> tuple[int, ...]:
        """PWM of every thruster at rest (disarmed)."""
        return tuple(round(r[2]) for r in self.ranges)


class ThrusterBank:
    """Thrust of each thruster [N] with first-order spin-up lag, and the τ it makes.

    Parameters
    ----------
    profile : thruster geometry and curves.
    voltage_V : battery voltage [V] for the thrust curves.
    lag_s : spin-up time constant [s] (0 for none).
    hunt : outputs inside the dead band hunt at its edge (module docstring).

    Attributes
    ----------
    reported_us : the PWM [µs] each thruster reports for the last command (the command,
        or the band edge it hunts at).
    """

    def __init__(self, profile: Profile, voltage_V: float, lag_s: float,
                 hunt: bool = False) -> None:
        self.ranges = [_pwm_range(profile, i) for i in range(len(profile.thrusters))]
        self._table = [tuple(float(f) for f in thrust_from_pwm(t.curve, np.arange(lo, hi + 1),
                                                                voltage_V))
                       for t, (lo, hi, _) in zip(profile.thrusters, self.ranges, strict=True)]
        #: per thruster: (first PWM below the band, first above it, neutral) [µs], or None
        self._band = [_true_band(table, r) if hunt else None
                      for table, r in zip(self._table, self.ranges, strict=True)]
        self.reported_us: tuple[int, ...] = tuple(round(r[2]) for r in self.ranges)
        self._T = tuple(tuple(float(v) for v in row)
                        for row in thrust_configuration(profile.thrusters))
        self.lag_s = lag_s
        self.force_N: tuple[float, ...] = (0.0,) * len(profile.thrusters)
        self._lag_dt = math.nan        # the step [s] of the cached lag factor
        self._lag_factor = 1.0

    def thrust(self, pwm_us: Sequence[int]) -> tuple[float, ...]:
        """Static thrust [N] of integer PWM commands (the profile's curve, saturated)."""
        return tuple([table[(lo if p < lo else hi if p > hi else p) - lo]
                      for table, p, (lo, hi, _) in zip(self._table, pwm_us, self.ranges,
                                                       strict=True)])

    def _hunting(self, pwm_us: Sequence[int]) -> tuple[float, ...]:
        """Thrust [N] of ``pwm_us`` with outputs in the dead band hunting at its edge; sets
        :attr:`reported_us`."""
        target = list(self.thrust(pwm_us))
        reported = list(pwm_us)
        for i, (band, p) in enumerate(zip(self._band, pwm_us, strict=True)):
            if band is None:
                continue
            below, above, neutral = band
            if below < p < above and p != neutral:
                edge = above if p > neutral else below
                reported[i] = edge
                target[i] = self.thrust_at(i, edge) * (p - neutral) / (edge - neutral)
        self.reported_us = tuple(reported)
        return tuple(target)

    def thrust_at(self, i: int, pwm_us: int) -> float:
        """Static thrust [N] of thruster ``i`` at one integer PWM [µs]."""
        lo, hi, _ = self.ranges[i]
        return self._table[i][min(max(pwm_us, lo), hi) - lo]

    def step(self, pwm_us: Sequence[int], dt: float) -> tuple[float, ...]:
        """Advance the spin-up lag by ``dt`` [s] towards the thrust of ``pwm_us``; return
        τ [N, N·m] (body FRD) of the thrust reached."""
        if any(b is not None for b in self._band):
            target = self._hunting(pwm_us)
        else:
            target = self.thrust(pwm_us)
            self.reported_us = tuple(pwm_us)
        if dt != self._lag_dt:
            self._lag_dt = dt
            self._lag_factor = 1.0 if self.lag_s <= 0 else 1.0 - math.exp(-dt / self.lag_s)
        a = self._lag_factor
        self.force_N = f = tuple([x + a * (y - x) for x, y in zip(self.force_N, target,
                                                                  strict=True)])
        return tuple([sum(map(mul, row, f)) for row in self._T])
