"""Disturbance torques sized by the attitude wander they leave through the attitude loop.

A slowly varying torque d about roll or pitch (waves, a tether, current on the frame) is
fought by the attitude controller, so the vehicle's attitude wanders only by what the loop
lets through while its thrusters' effort wanders by nearly all of d. Linearised about a
hold, one axis with inertia J (rigid body plus added mass) [kg·m²], linear damping
D [N·m·s/rad], hydrostatic stiffness k [N·m/rad] and the PID of
:class:`trimd.drivers.sim.controller.Controller` (Kp, Ki, Kd), the attitude error e
follows

    E(s)/D(s) = s / (J·s³ + (Kd + D)·s² + (Kp + k)·s + Ki).

For d a first-order Gauss–Markov process of standard deviation σ_d and correlation time τ
(power spectral density 2·σ_d²·τ/(1 + ω²·τ²)), the variance of e is

    σ_e² = σ_d² · (1/π) ∫₀^∞ |E/D(jω)|² · 2τ/(1 + ω²τ²) dω,

so the torque that leaves a given RMS wander follows from one integral (thruster lag and
the dead band left out: the simulator's wander is then within ≈ 20 % of the stated one,
checked in ``tests/drivers/test_sim_disturbance.py``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["torque_std_for_wander"]

#: Frequencies of the integral [rad/s]: well below any correlation time's corner and
#: well above any attitude loop's bandwidth.
_OMEGA = np.logspace(-5, 3, 4000)


def torque_std_for_wander(wander_rad: float, tau_s: float, inertia: float, damping: float,
                          stiffness: float, kp: float, ki: float, kd: float) -> float:
    """Standard deviation [N·m] of a Gauss–Markov torque (correlation time ``tau_s`` [s])
    that leaves an attitude wander of ``wander_rad`` [rad] RMS through the loop of the
    module docstring (``inertia`` [kg·m²], ``damping`` [N·m·s/rad], ``stiffness``
    [N·m/rad], PID gains in N·m per rad, rad·s, rad/s).

    Examples
    --------
    >>> round(torque_std_for_wander(math.radians(0.1), 5.0, 1.0, 0.0, 0.0, 12.0, 8.0, 6.0), 4)
    0.0409
    """
    s = 1j * _OMEGA
    h = s / (inertia * s**3 + (kd + damping) * s**2 + (kp + stiffness) * s + ki)
    spectrum = 2 * tau_s / (1 + (_OMEGA * tau_s) ** 2)
    gain2 = float(np.trapezoid(np.abs(h) ** 2 * spectrum, _OMEGA)) / math.pi
    return wander_rad / math.sqrt(gain2)
