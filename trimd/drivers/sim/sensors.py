"""Sensors and environment of the simulated vehicle: noisy AHRS, depth, DVL, water current.

Everything is seeded and deterministic. White noise is drawn in blocks (one numpy call per
thousand steps, not per step). Levels (``SimConfig``) are standard deviations in SI units,
all scaled by ``SimConfig.noise``:

* attitude (the AHRS estimate the controller and telemetry see) [rad];
* body rates [rad/s], plus a constant gyro bias drawn once per seed [rad/s];
* depth [m] and the vertical-speed estimate [m/s] (depth hold's derivative term);
* body velocity over ground [m/s] (a DVL, when fitted); the horizontal position that
  station keeping uses is the true one (a perfect position fix);
* the water current: a horizontal NED velocity of mean speed ``current_m_s`` whose speed
  and direction wander slowly (periods of 10 and 15 min) with seeded phases.

On top of these, the slow disturbances of :mod:`trimd.drivers.sim.disturbance` when they
are on: an AHRS roll/pitch error, a varying gyro bias, a depth-sensor error and a
varying current.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.disturbance import Disturbances
from trimd.drivers.sim.dynamics import State, euler_from_quaternion

__all__ = ["Reading", "Sensors"]

_BLOCK = 1024


class Reading(NamedTuple):
    """What the vehicle's sensors report at one instant (FRD/NED, SI).

    Immutable; a named tuple rather than a frozen dataclass because one is built every
    step and a frozen dataclass takes several times longer to construct."""

    t_s: float
    phi: float
    theta: float
    psi: float
    p: float
    q: float
    r: float
    depth_m: float
    depth_rate_m_s: float
    u: float
    v: float
    w: float
    north_m: float
    east_m: float


class Sensors:
    """Noisy measurements of the true state, and the water current, for one seed.

    Parameters
    ----------
    config : noise levels, current and seed.
    disturbances : the slow disturbances (stepped by the vehicle).
    """

    def __init__(self, config: SimConfig, disturbances: Disturbances) -> None:
        c = config
        self.disturbances = disturbances
        self._rng = np.random.default_rng(c.seed)
        self.gyro_bias = tuple(float(b) for b in
                               c.noise * c.gyro_bias_rad_s * self._rng.standard_normal(3))
        self._phase = tuple(float(a) for a in self._rng.uniform(0, 2 * math.pi, 3))
        self._current = c.current_m_s
        self._scale = tuple(c.noise * v for v in (
            c.attitude_noise_rad, c.attitude_noise_rad, c.attitude_noise_rad,
            c.rate_noise_rad_s, c.rate_noise_rad_s, c.rate_noise_rad_s, c.depth_noise_m,
            c.depth_rate_noise_m_s, c.dvl_noise_m_s, c.dvl_noise_m_s, c.dvl_noise_m_s))
        self._block: list[tuple[float, ...]] = []
        self._next = 0

    def _noise(self) -> tuple[float, ...]:
        if self._next >= len(self._block):
            draws = self._rng.standard_normal((_BLOCK, len(self._scale))) * self._scale
            self._block = [tuple(row) for row in draws.tolist()]
            self._next = 0
        self._next += 1
        return self._block[self._next - 1]

    def read(self, t_s: float, x: State) -> Reading:
        """Measure state ``x`` at time ``t_s`` [s]."""
        n = self._noise()
        north, east, depth, q0, q1, q2, q3, u, v, w, p, q, r = x
        phi, theta, psi = euler_from_quaternion(q0, q1, q2, q3)
        depth_rate = (2.0 * (q1 * q3 - q0 * q2) * u + 2.0 * (q2 * q3 + q0 * q1) * v
                      + (1.0 - 2.0 * (q1 * q1 + q2 * q2)) * w)
        bp, bq, br = self.gyro_bias
        d = self.disturbances
        if d.active:
            phi, theta = phi + d.ahrs_rad[0], theta + d.ahrs_rad[1]
            depth += d.depth_m
            bp, bq, br = bp + d.gyro_rad_s[0], bq + d.gyro_rad_s[1], br + d.gyro_rad_s[2]
        return Reading(t_s, phi + n[0], theta + n[1], _wrap(psi + n[2]),
                       p + bp + n[3], q + bq + n[4], r + br + n[5],
                       depth + n[6], depth_rate + n[7], u + n[8], v + n[9], w + n[10],
                       north, east)

    def current(self, t_s: float) -> tuple[float, float, float]:
        """Water current [m/s] in NED at ``t_s`` (horizontal, slowly varying)."""
        c = self._current
        cn, ce = self.disturbances.current_m_s
        if c == 0.0:
            return (cn, ce, 0.0) if cn or ce else (0.0, 0.0, 0.0)
        a, b, d = self._phase
        speed = c * (1.0 + 0.3 * math.sin(2 * math.pi * t_s / 600.0 + a))
        heading = d + 0.5 * math.sin(2 * math.pi * t_s / 900.0 + b)
        return (speed * math.cos(heading) + cn, speed * math.sin(heading) + ce, 0.0)


def _wrap(angle: float) -> float:
    """Angle wrapped to (−π, π] [rad]."""
    return math.atan2(math.sin(angle), math.cos(angle))
