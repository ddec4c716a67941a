"""Typed samples and commands that cross the link boundary (SI units, FRD/NED).

Every sample carries ``t_s``: the time it was received [s] on the link's own clock
(``time.monotonic()`` for live links, simulated time for the simulator, the log's time
for a replay). The core measures every timeout and window on these stamps.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

__all__ = [
    "Arm",
    "Attitude",
    "Battery",
    "Command",
    "Confirmed",
    "Depth",
    "Health",
    "HoldAttitude",
    "ModeClass",
    "OpenLoop",
    "PilotInput",
    "Release",
    "Sample",
    "Thrusters",
    "VehicleText",
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


class ModeClass(Enum):
    """What a vehicle's flight mode does, whatever the vehicle calls it: each driver maps
    its own vocabulary (ArduSub's mode numbers, a serial vehicle's mode tokens, a log's
    mode records) to one of these, and the core and the application reason on the class
    only (the mode's name is for people)."""

    #: the pilot's sticks drive the thrusters directly (ArduSub MANUAL, ACRO)
    MANUAL = "manual"
    #: the autopilot holds the attitude, the pilot's throttle sets the vertical thrust
    #: (ArduSub STABILIZE)
    STABILISED = "stabilised"
    #: the autopilot holds attitude and depth at the pilot's targets (ArduSub ALT_HOLD,
    #: POSHOLD)
    DEPTH_HOLDING = "depth-holding"
    #: the autopilot follows its own plan or reference, holding attitude and depth on the
    #: way (ArduSub AUTO, GUIDED, CIRCLE, SURFTRAK)
    AUTONOMOUS = "autonomous"
    #: the vehicle surfaces or otherwise runs its failsafe (ArduSub SURFACE)
    FAILSAFE = "failsafe"
    #: the autopilot runs a routine of its own that is not flying, e.g. ArduSub's
    #: MOTOR_DETECT
    SERVICE = "service"
    #: the driver does not know the mode (or was told none)
    UNKNOWN = "unknown"


@dataclass(frozen=True, slots=True)
class Health:
    """Link and vehicle state: heartbeat seen, mode, armed, bad frames so far.

    ``mode`` is the mode's name as the vehicle gives it (for people); ``mode_class`` what
    that mode does (:class:`ModeClass`, the driver's mapping). ``armed`` is None when the
    source does not report arming (a DataFlash log without ARM records). ``detail`` is the
    link's warnings (or, when not connected, why); ``vehicle`` names the vehicle as the
    link identifies it (e.g. ``"sysid 1 ArduPilot submarine"``), "" when the link cannot
    tell.
    """

    t_s: float
    connected: bool
    mode: str
    armed: bool | None
    bad_frames: int = 0
    detail: str = ""
    vehicle: str = ""
    mode_class: ModeClass = ModeClass.UNKNOWN

    def warnings(self) -> list[str]:
        """The link's warnings so far (from ``detail`` while connected)."""
        return self.detail.split("; ") if self.connected and self.detail else []


@dataclass(frozen=True, slots=True)
class VehicleText:
    """A message the vehicle sent for people (MAVLink STATUSTEXT), e.g. a failsafe.

    ``severity`` follows MAV_SEVERITY: 0 emergency … 3 error, 4 warning … 7 debug.
    """

    t_s: float
    severity: int
    text: str

    @property
    def level(self) -> str:
        """``"error"`` (severity 0–3), ``"warning"`` (4) or ``"info"`` (5–7)."""
        return "error" if self.severity <= 3 else "warning" if self.severity == 4 else "info"


@dataclass(frozen=True, slots=True)
class PilotInput:
    """Someone other than trimd is flying the vehicle: stick input beyond neutral from
    another station, a mode change trimd did not ask for, or a serial vehicle handing
    control back. ``source`` says which, in words for the operator."""

    t_s: float
    source: str


@dataclass(frozen=True, slots=True)
class Confirmed:
    """In a recording: trimd began commanding the vehicle here, so the operator's
    confirmation (or ``--yes``) took effect at this point. A replay confirms here, so its
    holds start at the very sample the live ones did."""

    t_s: float


Sample = (Attitude | Thrusters | Depth | Velocity | Battery | Health | VehicleText | PilotInput
          | Confirmed)


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
