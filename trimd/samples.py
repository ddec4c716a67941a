"""Typed samples and commands that cross the link boundary (SI units, FRD/NED).

Every sample carries ``t_s``: the time it was received [s] on the link's own clock
(``time.monotonic()`` for live links, simulated time for the simulator, the log's time
for a replay). The core measures every timeout and window on these stamps.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "Arm",
    "Attitude",
    "Battery",
    "Command",
    "Depth",
    "Health",
    "HoldAttitude",
    "OpenLoop",
    "Release",
    "Sample",
    "Thrusters",
    "Velocity",
]


@dataclass(frozen=True, slots=True)
class Attitude:
    """Roll φ, pitch θ, yaw ψ [rad] (ZYX Euler, NED→FRD) and body rates p, q, r [rad/s]."""

    t_s: float
    phi: float
    theta: float
    psi: float
    p: float
    q: float
    r: float


@dataclass(frozen=True, slots=True)
class Thrusters:
    """Per-thruster output [µs PWM], in the profile's thruster order."""

    t_s: float
    pwm_us: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class Depth:
    """Depth below the surface [m], positive down (NED z)."""

    t_s: float
    depth_m: float


@dataclass(frozen=True, slots=True)
class Velocity:
    """Body-frame linear velocity u, v, w [m/s] (a DVL), FRD."""

    t_s: float
    u: float
    v: float
    w: float


@dataclass(frozen=True, slots=True)
class Battery:
    """Battery voltage [V] (the thrust curve depends on it)."""

    t_s: float
    voltage_V: float


@dataclass(frozen=True, slots=True)
class Health:
    """Link and vehicle state: heartbeat seen, mode name, armed, bad frames so far."""

    t_s: float
    connected: bool
    mode: str
    armed: bool
    bad_frames: int = 0
    detail: str = ""


Sample = Attitude | Thrusters | Depth | Velocity | Battery | Health


@dataclass(frozen=True, slots=True)
class HoldAttitude:
    """Hold roll, pitch, yaw [rad] with depth hold at the present depth."""

    phi: float
    theta: float
    psi: float


@dataclass(frozen=True, slots=True)
class Release:
    """Stop commanding: give control back to the pilot / the vehicle's previous mode."""


@dataclass(frozen=True, slots=True)
class OpenLoop:
    """Open-loop per-axis input in [-1, 1]: surge, sway, heave, roll, pitch, yaw."""

    axes: tuple[float, float, float, float, float, float]


@dataclass(frozen=True, slots=True)
class Arm:
    """Arm (True) or disarm (False) where the vehicle allows it."""

    armed: bool


Command = HoldAttitude | Release | OpenLoop | Arm
