"""Vehicle profiles: validated, immutable descriptions of a vehicle (``trimd/profiles/``).

Every quantity is SI and every YAML key carries its unit (``mass_kg``, ``position_m``).
Positions are in the body frame FRD with the origin at CG0, the centre of gravity of the
nominal (balanced) vehicle. The schema is documented in ``docs/profile.md``; a problem is
reported as one :class:`~trimd.core.errors.ProfileError` naming the file, the key path and
what was expected. Parsing and loading YAML: :mod:`trimd.core.profile_yaml`.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from trimd.core.errors import ProfileError
from trimd.core.types import Vec3

if TYPE_CHECKING:
    from trimd.core.map_posterior import ThrustMapPosterior

__all__ = [
    "PIECE_UNCERTAINTY_PCT",
    "BallastPiece",
    "BallastSlot",
    "HoldSetpoint",
    "InstalledPiece",
    "ProcedureLimits",
    "Profile",
    "ThrustCurve",
    "ThrustTable",
    "Thruster",
]

Vec6 = tuple[float, float, float, float, float, float]
#: Default 1σ [%] of a ballast piece's net force in water, by kind.
PIECE_UNCERTAINTY_PCT = {"weight": 1.0, "float": 5.0}


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
    ``deadband_margin_us`` is how far [µs] a real ESC's dead band may start from the
    table's: within it of a band edge (or inside the band) a sample's thrust is uncertain
    by up to the edge thrust (docs/method.md §3, "The thrust map near the dead band").
    """

    name: str
    tables: tuple[ThrustTable, ...]
    neutral_us: float = 1500.0
    uncertainty_pct: float = 5.0
    deadband_margin_us: float = 5.0


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
    ``uncertainty_pct`` is the relative standard deviation [%] of that net force, shared
    by every piece of the kind (a calibration experiment rests on it): by default
    :data:`PIECE_UNCERTAINTY_PCT` of its kind (lead is weighed to ≈ 1 %, foam's lift
    depends on its volume and water uptake).
    """

    name: str
    kind: Literal["weight", "float"]
    mass_kg: float
    volume_m3: float
    count: int
    uncertainty_pct: float | None = None

    def net_down_N(self, water_density_kg_m3: float, gravity_m_s2: float) -> float:
        """Net downward force of one piece in water [N] (negative: lift)."""
        return (self.mass_kg - water_density_kg_m3 * self.volume_m3) * gravity_m_s2

    @property
    def net_uncertainty_pct(self) -> float:
        """``uncertainty_pct``, or the default of the piece's kind [%]."""
        return (PIECE_UNCERTAINTY_PCT[self.kind] if self.uncertainty_pct is None
                else self.uncertainty_pct)

    def capacity_kg(self, water_density_kg_m3: float) -> float:
        """What one piece uses of a slot: its mass [kg] for a weight, its lift [kgf] for a
        float."""
        lift = water_density_kg_m3 * self.volume_m3 - self.mass_kg
        return self.mass_kg if self.kind == "weight" else lift


@dataclass(frozen=True, slots=True)
class InstalledPiece:
    """``count`` pieces of inventory kind ``piece`` mounted in ``slot`` (ballast already on
    the vehicle: the net quantities a trim measures include it)."""

    slot: str
    piece: str
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
    #: How fast [deg/s] a commanded roll or pitch moves to a new hold's: a step of 20°
    #: made the simulated small-payload Heavy overshoot past 30° (its thrusters idle in
    #: their dead band); at 5°/s it did not.
    tilt_rate_deg_s: float = 5.0


@dataclass(frozen=True, slots=True)
class Profile:
    """A validated vehicle profile. Units: kg, m, N, s; frames: body FRD, world NED.

    ``holds_station``: the vehicle holds horizontal position during a hold (a position
    fix); otherwise it keeps depth and drifts at a tilt (:mod:`trimd.core.drift`).
    ``inventory`` counts the spare pieces on hand; ``installed`` is the ballast the
    profile declares already mounted (``ballast.installed``).
    ``attitude_error_deg``: 1σ of the attitude reference's slow error in roll and pitch
    [deg] (an AHRS at rest wanders by ≈ 0.1° over tens of seconds): constant over one hold,
    so collecting does not average it out.
    ``thrust_map``: what the vehicle's calibration experiments taught about its thrust map
    (:mod:`trimd.core.calibration`, from the trim history, never from the YAML); None: the
    profile's curves with their stated uncertainty."""

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
    installed: tuple[InstalledPiece, ...] = ()
    thrust_map: ThrustMapPosterior | None = None

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

    def piece(self, name: str) -> BallastPiece:
        """The inventory piece called ``name``; ProfileError listing the pieces if none."""
        for p in self.inventory:
            if p.name.lower() == name.lower():
                return p
        names = ", ".join(p.name for p in self.inventory) or "none"
        raise ProfileError(f"{self.source}: no inventory piece '{name}' (pieces: {names})")

    def resolve_installed(self, pieces: Sequence[InstalledPiece], where: str
                          ) -> tuple[InstalledPiece, ...]:
        """``pieces`` checked against this profile: slot and piece names known (spelled as
        the profile spells them), whole counts ≥ 0, weights only in slots that take weight
        and floats only where floats go, each slot within its capacity. Pieces of the same
        kind in the same slot are merged and zero counts dropped. ``where`` names the list
        in every error (``ballast.installed``, ``the history``, ``--set``).
        """
        merged: dict[tuple[str, str], int] = {}
        for i, item in enumerate(pieces):
            here = f"{self.source}: {where}[{i}]"
            slot = _named(self.slots, item.slot, "ballast slot", here)
            piece = _named(self.inventory, item.piece, "inventory piece", here)
            if isinstance(item.count, bool) or item.count != int(item.count) or item.count < 0:
                raise ProfileError(f"{here}: count: expected a whole number >= 0, got "
                                   f"{item.count!r}")
            merged[(slot.name, piece.name)] = merged.get((slot.name, piece.name), 0) + int(
                item.count)
        out = tuple(InstalledPiece(s, p, n) for (s, p), n in merged.items() if n > 0)
        for slot in self.slots:
            for kind, room, unit in (("weight", slot.max_weight_kg, "kg"),
                                     ("float", slot.max_float_kg, "kgf")):
                used = sum(n * self.piece(p).capacity_kg(self.water_density_kg_m3)
                           for s, p, n in ((x.slot, x.piece, x.count) for x in out)
                           if s == slot.name and self.piece(p).kind == kind)
                if used > room + 1e-9:
                    raise ProfileError(f"{self.source}: {where}: slot {slot.name} takes "
                                       f"{room:g} {unit} of {kind}; {used:g} {unit} installed")
        return out


def _named(things: Sequence[BallastSlot] | Sequence[BallastPiece], name: str, what: str,
           where: str) -> BallastSlot | BallastPiece:
    """The slot or piece called ``name`` (any case); ProfileError with the nearest name."""
    for t in things:
        if t.name.lower() == str(name).lower():
            return t
    names = [t.name for t in things]
    near = difflib.get_close_matches(str(name), names, n=1)
    hint = f"did you mean '{near[0]}'? " if near else ""
    raise ProfileError(f"{where}: no {what} '{name}' ({hint}{what}s: "
                       f"{', '.join(names) or 'none'})")
