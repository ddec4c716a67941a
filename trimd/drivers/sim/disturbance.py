"""Slow disturbances of the simulated vehicle: first-order Gauss–Markov processes.

A first-order Gauss–Markov process of standard deviation σ and correlation time τ, sampled
every dt, is

    x[k+1] = a·x[k] + σ·√(1 − a²)·w[k],   a = exp(−dt/τ),   w[k] ~ N(0, 1)

(the exact discretisation of ẋ = −x/τ + white noise): stationary, zero mean, variance σ²,
autocorrelation exp(−|lag|/τ). Each process starts from its stationary distribution, so a
run has the stated amplitude from its first step. Trajectories are computed a block of
steps at a time (one ``scipy.signal.lfilter`` call per thousand steps), so a step costs an
index.

:class:`Disturbances` holds every process a :class:`~trimd.drivers.sim.config.SimConfig`
switches on, each from its own seeded random stream: switching one on or off changes none
of the others, nor the white sensor noise.
"""

from __future__ import annotations

import math

import numpy as np

from trimd.drivers.sim.config import SimConfig

__all__ = ["Disturbances", "GaussMarkov"]

_BLOCK = 1024
_ZERO2 = (0.0, 0.0)
_ZERO3 = (0.0, 0.0, 0.0)


class GaussMarkov:
    """``n`` independent first-order Gauss–Markov processes (module docstring).

    Parameters
    ----------
    sigma : stationary standard deviation σ (any unit; the samples have it).
    tau_s : correlation time τ [s] (> 0).
    dt_s : sample interval [s].
    n : number of independent components.
    rng : the random stream (one per process).

    Examples
    --------
    >>> gm = GaussMarkov(0.5, 10.0, 0.01, 2, np.random.default_rng(0))
    >>> x = np.array([gm.step() for _ in range(200_000)])
    >>> bool(np.all(np.abs(x.std(axis=0) / 0.5 - 1) < 0.3))
    True
    """

    def __init__(self, sigma: float, tau_s: float, dt_s: float, n: int,
                 rng: np.random.Generator) -> None:
        if not tau_s > 0:
            raise ValueError(f"a Gauss–Markov correlation time must be positive, got {tau_s}")
        self.sigma, self.tau_s, self.n = sigma, tau_s, n
        self._a = math.exp(-dt_s / tau_s)
        self._b = sigma * math.sqrt(1.0 - self._a ** 2)
        self._rng = rng
        self._x = sigma * rng.standard_normal(n)     # stationary start
        self._block: list[tuple[float, ...]] = []
        self._next = 0

    def step(self) -> tuple[float, ...]:
        """The next sample of the ``n`` components."""
        if self._next >= len(self._block):
            from scipy.signal import lfilter  # 1 s to import: only once a process is on

            w = self._b * self._rng.standard_normal((_BLOCK, self.n))
            x, _ = lfilter([1.0], [1.0, -self._a], w, axis=0, zi=self._a * self._x[None, :])
            self._x = x[-1]
            self._block = [tuple(row) for row in x.tolist()]
            self._next = 0
        self._next += 1
        return self._block[self._next - 1]


class Disturbances:
    """Every slow disturbance ``config`` switches on (an amplitude of 0 is off), stepped
    once per simulation step. Units of what :meth:`step` sets (SI, frames as named):

    Attributes
    ----------
    ahrs_rad : error of the AHRS roll and pitch estimate [rad].
    setpoint_rad : wander of the attitude the controller holds, roll and pitch [rad].
    depth_m : error of the depth sensor [m] (positive reads deeper).
    current_m_s : varying part of the water current, north and east [m/s] (NED).
    gyro_rad_s : varying part of the gyro bias, p, q, r [rad/s] (body FRD).
    dither_us : PWM added to each thruster's output [µs], ``()`` when off.
    torque_Nm : disturbance torque about roll and pitch [N·m] (body FRD), of standard
        deviations ``torque_std_Nm`` (:mod:`trimd.drivers.sim.wander` sizes them).
    """

    def __init__(self, config: SimConfig, n_thrusters: int,
                 torque_std_Nm: tuple[float, float] = _ZERO2) -> None:
        c = config
        dt = c.dt_s

        def process(stream: int, sigma: float, tau_s: float, n: int) -> GaussMarkov | None:
            if sigma == 0.0:
                return None
            return GaussMarkov(sigma, tau_s, dt, n, np.random.default_rng([c.seed, stream]))

        self._ahrs = process(1, math.radians(c.ahrs_wander_deg), c.ahrs_wander_tau_s, 2)
        self._setpoint = process(2, math.radians(c.attitude_wander_deg),
                                 c.attitude_wander_tau_s, 2)
        self._depth = process(3, c.depth_wander_m, c.depth_wander_tau_s, 1)
        self._current = process(4, c.current_wander_m_s, c.current_wander_tau_s, 2)
        self._gyro = process(5, math.radians(c.gyro_wander_deg_s), c.gyro_wander_tau_s, 3)
        self._dither = process(6, c.thruster_dither_us, c.thruster_dither_tau_s, n_thrusters)
        self._torque = process(7, 1.0 if any(torque_std_Nm) else 0.0, c.torque_wander_tau_s, 2)
        self._torque_std = torque_std_Nm
        self.ahrs_rad: tuple[float, ...] = _ZERO2
        self.setpoint_rad: tuple[float, ...] = _ZERO2
        self.depth_m = 0.0
        self.current_m_s: tuple[float, ...] = _ZERO2
        self.gyro_rad_s: tuple[float, ...] = _ZERO3
        self.dither_us: tuple[float, ...] = ()
        self.torque_Nm: tuple[float, ...] = _ZERO2
        self.active = any(p is not None for p in (self._ahrs, self._setpoint, self._depth,
                                                  self._current, self._gyro, self._dither,
                                                  self._torque))
        self.step()

    def step(self) -> None:
        """Advance every process that is on by one step."""
        if not self.active:
            return
        if self._ahrs is not None:
            self.ahrs_rad = self._ahrs.step()
        if self._setpoint is not None:
            self.setpoint_rad = self._setpoint.step()
        if self._depth is not None:
            self.depth_m = self._depth.step()[0]
        if self._current is not None:
            self.current_m_s = self._current.step()
        if self._gyro is not None:
            self.gyro_rad_s = self._gyro.step()
        if self._dither is not None:
            self.dither_us = self._dither.step()
        if self._torque is not None:
            unit = self._torque.step()
            self.torque_Nm = (unit[0] * self._torque_std[0], unit[1] * self._torque_std[1])
