"""Vehicle profiles: validated, immutable descriptions of a vehicle (``trimd/profiles/``).

Every quantity is SI and every YAML key carries its unit (``mass_kg``, ``position_m``).
Positions are in the body frame FRD with the origin at CG0, the centre of gravity of the
nominal (balanced) vehicle. The schema is documented in ``docs/profile.md``; a problem is
reported as one :class:`~trimd.core.errors.ProfileError` naming the file, the key path and
what was expected. Parsing and loading YAML: :mod:`trimd.core.profile_yaml`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from trimd.core.errors import ProfileError

__all__ = [
    "BallastPiece",
    "BallastSlot",
    "HoldSetpoint",
    "ProcedureLimits",
    "Profile",
    "ThrustCurve",
    "ThrustTable",
    "Thruster",
]

Vec3 = tuple[float, float, float]
Vec6 = tuple[float, float, float, float, float, float]


@dataclass(frozen=True, slots=True)
class ThrustTable:
    """Static thrust [N] against PWM [µs] at one battery voltage [V].

    Inside ``deadband_us`` (inclusive) the thrust is zero; ``pwm_us`` is increasing.
    """

    voltage_V: float
    deadband_us: tuple[float, float]
    pwm_us: tuple[float, ...]
    thrust_N: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class ThrustCurve:
    """A thruster model: one or more tables, interpolated linearly on battery voltage.

    ``uncertainty_pct`` is the relative standard deviation [%] of a real thruster's thrust
    about the table, separately for each thruster and each direction of thrust (a table
    from the maker, a worn propeller, a fouled duct): a gain error every hold shares.
    """

    name: str
    tables: tuple[ThrustTable, ...]
    neutral_us: float = 1500.0
    uncertainty_pct: float = 5.0


@dataclass(frozen=True, slots=True)
class Thruster:
    """One thruster. ``direction`` is the unit force direction (body FRD) of a positive
    output (PWM above neutral); ``reversed`` flips it, as ArduSub's MOT_n_DIRECTION = -1."""

    name: str
    channel: int
    position_m: Vec3
    direction: Vec3
    curve: ThrustCurve
    reversed: bool = False


@dataclass(frozen=True, slots=True)
class BallastSlot:
    """A place where ballast can be mounted (body FRD, metres) and how much it takes.

    ``max_float_kg`` is the lift capacity of buoyant material, in kilograms-force.
    """

    name: str
    position_m: Vec3
    max_weight_kg: float
    max_float_kg: float


@dataclass(frozen=True, slots=True)
class BallastPiece:
    """A kind of ballast piece in the inventory (a lead block, a foam block).

    Its net downward force in water is ``mass_kg·g − rho·g·volume_m3`` (negative: lift).
    """

    name: str
    kind: Literal["weight", "float"]
    mass_kg: float
    volume_m3: float
    count: int


@dataclass(frozen=True, slots=True)
class HoldSetpoint:
    """An attitude the procedure holds: roll and pitch in degrees (for people)."""

    roll_deg: float
    pitch_deg: float


@dataclass(frozen=True, slots=True)
class ProcedureLimits:
    """Limits and tolerances of the trim procedure; every time is in sample time [s]."""

    max_tilt_deg: float
    max_depth_excursion_m: float
    attitude_tol_deg: float
    rate_tol_deg_s: float
    min_steady_s: float
    settle_timeout_s: float
    collect_max_s: float
    connect_timeout_s: float
    link_timeout_s: float


@dataclass(frozen=True, slots=True)
class Profile:
    """A validated vehicle profile. Units: kg, m, N, s; frames: body FRD, world NED.

    ``holds_station``: the vehicle holds horizontal position during a hold (a position
    fix); otherwise it keeps depth and drifts at a tilt (:mod:`trimd.core.drift`).
    ``attitude_error_deg``: 1σ of the attitude reference's slow error in roll and pitch
    [deg] (an AHRS at rest wanders by ≈ 0.1° over tens of seconds): constant over one hold,
    so collecting does not average it out."""

    name: str
    source: str
    mass_kg: float
    gravity_m_s2: float
    water_density_kg_m3: float
    buoyancy_N: float
    r_b_m: Vec3
    inertia_kg_m2: Vec3
    added_mass: Vec6
    linear_damping: Vec6
    quadratic_damping: Vec6
    nominal_voltage_V: float
    thrusters: tuple[Thruster, ...]
    slots: tuple[BallastSlot, ...]
    inventory: tuple[BallastPiece, ...]
    net_buoyancy_pct: tuple[float, float]
    level_tol_deg: float
    holds: tuple[HoldSetpoint, ...]
    procedure: ProcedureLimits
    frame_config: int | None = None
    holds_station: bool = False
    attitude_error_deg: float = 0.1

    @property
    def weight_N(self) -> float:
        """Weight of the nominal vehicle, m·g [N]."""
        return self.mass_kg * self.gravity_m_s2

    def slot(self, name: str) -> BallastSlot:
        """The slot called ``name``; ProfileError listing the slots if there is none."""
        for s in self.slots:
            if s.name.lower() == name.lower():
                return s
        names = ", ".join(s.name for s in self.slots) or "none"
        raise ProfileError(f"{self.source}: no ballast slot '{name}' (slots: {names})")
