"""Reading vehicle profiles from YAML: every error names the file, the key path and the problem.

The schema is documented in ``docs/profile.md``; the types it builds are in
:mod:`trimd.core.profile`. Shipped profiles (``trimd/profiles/*.yaml``) are package
data, found by name through :mod:`importlib.resources`.
"""

from __future__ import annotations

import dataclasses
import difflib
import itertools
import math
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Literal

import yaml

from trimd.core.errors import ProfileError
from trimd.core.profile import (
    BallastPiece,
    BallastSlot,
    HoldSetpoint,
    InstalledPiece,
    ProcedureLimits,
    Profile,
    ThrustCurve,
    Thruster,
    ThrustTable,
)
from trimd.core.types import Vec3

__all__ = ["load_profile", "parse_profile", "read_profile_text", "shipped_profiles"]


class _Node:
    """A YAML mapping with its key path, so every error names file and key."""

    def __init__(self, data: object, path: str, source: str) -> None:
        if not isinstance(data, dict):
            raise ProfileError(f"{source}: {path or '<top>'}: expected a mapping, got "
                               f"{type(data).__name__}")
        self.data: dict[str, object] = data
        self.path = path
        self.source = source
        self.used: set[str] = set()

    def _key(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def fail(self, key: str, what: str) -> ProfileError:
        return ProfileError(f"{self.source}: {self._key(key)}: {what}")

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: object = ...) -> object:
        if key not in self.data:
            if default is ...:
                near = difflib.get_close_matches(key, [str(k) for k in self.data], n=1)
                hint = f"; is '{near[0]}' a typo of it?" if near else ""
                raise self.fail(key, f"missing (required){hint}")
            return default
        self.used.add(key)
        return self.data[key]

    def number(self, key: str, default: object = ..., *, minimum: float | None = None,
               positive: bool = False) -> float:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(
                value):
            raise self.fail(key, f"expected a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.fail(key, f"expected a positive number, got {value!r}")
        if minimum is not None and value < minimum:
            raise self.fail(key, f"expected a number >= {minimum}, got {value!r}")
        return float(value)

    def vector(self, key: str, n: int, default: object = ...) -> tuple[float, ...]:
        value = self.raw(key, default)
        if not isinstance(value, list | tuple) or len(value) != n or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                for v in value):
            raise self.fail(key, f"expected a list of {n} finite numbers, got {value!r}")
        return tuple(float(v) for v in value)

    def text(self, key: str, default: object = ...) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str) or not value:
            raise self.fail(key, f"expected a non-empty string, got {value!r}")
        return value

    def child(self, key: str, default: object = ...) -> _Node:
        return _Node(self.raw(key, default), self._key(key), self.source)

    def items(self, key: str, default: object = ...) -> list[_Node]:
        value = self.raw(key, default)
        if not isinstance(value, list):
            raise self.fail(key, f"expected a list, got {type(value).__name__}")
        return [_Node(v, f"{self._key(key)}[{i}]", self.source) for i, v in enumerate(value)]

    def done(self) -> None:
        """Reject keys nobody read: a typo or a wrong unit suffix must not pass silently."""
        for key in self.data:
            if key not in self.used:
                near = difflib.get_close_matches(str(key), self.used | _KNOWN_KEYS, n=1)
                hint = f" (did you mean '{near[0]}'?)" if near else ""
                raise self.fail(str(key), f"unknown key{hint}")


#: Procedure keys of older profiles, accepted and ignored: collecting now stops on
#: ``ballast.level_tol_deg`` and the buoyancy window (``trimd.core.decision``).
RETIRED_PROCEDURE_KEYS = ("target_cg_std_m", "target_m_ext_std_kg")


_KNOWN_KEYS = {
    "name", "description", "mass_kg", "gravity_m_s2", "water_density_kg_m3", "buoyancy",
    "force_N", "volume_m3", "centre_m", "inertia_kg_m2", "added_mass", "damping", "linear",
    "quadratic", "nominal_voltage_V", "thrust_curves", "thrusters", "ballast", "slots",
    "inventory", "holds", "procedure", "frame_config", "holds_station", "attitude_error_deg",
    "channel", "position_m",
    "direction",
    "curve", "reversed", "tables", "voltage_V", "deadband_us", "pwm_us", "thrust_N",
    "thrust_kgf", "neutral_us", "max_weight_kg", "max_float_kg", "kind", "count",
    "net_buoyancy_pct", "roll_deg", "pitch_deg", "max_tilt_deg", "max_depth_excursion_m",
    "attitude_tol_deg", "rate_tol_deg_s", "min_steady_s", "settle_timeout_s", "collect_max_s",
    "connect_timeout_s", "link_timeout_s", "tilt_rate_deg_s", "level_tol_deg", "uncertainty_pct",
    "deadband_margin_us",
    *RETIRED_PROCEDURE_KEYS,
    "installed", "slot", "piece",
    "surge_kg", "sway_kg", "heave_kg", "roll_kg_m2", "pitch_kg_m2", "yaw_kg_m2",
}

_G_STD = 9.80665


def _thrust_table(node: _Node) -> ThrustTable:
    voltage = node.number("voltage_V", positive=True)
    band = node.vector("deadband_us", 2)
    pwm = node.raw("pwm_us")
    n = len(pwm) if isinstance(pwm, list) else 0
    pwm_us = node.vector("pwm_us", n)
    if node.has("thrust_N"):
        thrust = node.vector("thrust_N", n)
    else:
        thrust = tuple(v * _G_STD for v in node.vector("thrust_kgf", n))
    if n < 2 or any(b <= a for a, b in itertools.pairwise(pwm_us)):
        raise node.fail("pwm_us", "expected at least 2 strictly increasing PWM values")
    if any(b < a for a, b in itertools.pairwise(thrust)):
        raise node.fail("thrust_N" if node.has("thrust_N") else "thrust_kgf",
                        "expected thrust that never falls as PWM rises (a thruster that "
                        "pushes backwards above neutral has reversed: true, not a falling "
                        f"table), got {[round(t, 3) for t in thrust]}")
    if not band[0] <= band[1] or any(band[0] < p < band[1] for p in pwm_us):
        raise node.fail("deadband_us", f"expected [low, high] with no table point inside, "
                                       f"got {list(band)}")
    node.done()
    return ThrustTable(voltage, (band[0], band[1]), pwm_us, thrust)


def _thrust_curve(name: str, node: _Node) -> ThrustCurve:
    tables = tuple(sorted((_thrust_table(t) for t in node.items("tables")),
                          key=lambda t: t.voltage_V))
    if not tables:
        raise node.fail("tables", "expected at least one table")
    uncertainty = node.number("uncertainty_pct", 5.0, minimum=0.0)
    if uncertainty >= 100:
        raise node.fail("uncertainty_pct", "expected a relative standard deviation below "
                                           f"100 %, got {uncertainty}")
    margin = node.number("deadband_margin_us", 5.0, minimum=0.0)
    curve = ThrustCurve(name, tables, node.number("neutral_us", 1500.0), uncertainty, margin)
    node.done()
    return curve


def _unit(node: _Node, key: str) -> Vec3:
    d = node.vector(key, 3)
    norm = math.sqrt(sum(v * v for v in d))
    if abs(norm - 1.0) > 1e-3:
        raise node.fail(key, f"expected a unit vector (norm 1), got norm {norm:.4f}")
    return (d[0] / norm, d[1] / norm, d[2] / norm)


def _thruster(node: _Node, curves: dict[str, ThrustCurve]) -> Thruster:
    curve_name = node.text("curve")
    if curve_name not in curves:
        raise node.fail("curve", f"unknown thrust curve '{curve_name}' "
                                 f"(defined: {', '.join(curves) or 'none'})")
    channel = node.number("channel", minimum=1)
    if channel != int(channel) or channel > 32:
        raise node.fail("channel", f"expected an output channel 1..32, got {channel}")
    reversed_ = node.raw("reversed", False)
    if not isinstance(reversed_, bool):
        raise node.fail("reversed", f"expected true or false, got {reversed_!r}")
    t = Thruster(node.text("name"), int(channel), _vec3(node, "position_m"),
                 _unit(node, "direction"), curves[curve_name], reversed_)
    node.done()
    return t


def _vec3(node: _Node, key: str, default: object = ...) -> Vec3:
    v = node.vector(key, 3, default)
    return (v[0], v[1], v[2])


def _piece(node: _Node, rho: float, g: float) -> BallastPiece:
    text = node.text("kind")
    kinds: dict[str, Literal["weight", "float"]] = {"weight": "weight", "float": "float"}
    if text not in kinds:
        raise node.fail("kind", f"expected 'weight' or 'float', got {text!r}")
    kind = kinds[text]
    count = node.number("count", minimum=0)
    if count != int(count):
        raise node.fail("count", f"expected a whole number, got {count}")
    piece = BallastPiece(node.text("name"), kind, node.number("mass_kg", minimum=0.0),
                         node.number("volume_m3", minimum=0.0), int(count),
                         node.number("uncertainty_pct", minimum=0.0)
                         if node.has("uncertainty_pct") else None)
    net = piece.mass_kg * g - rho * g * piece.volume_m3
    if (kind == "weight") != (net > 0):
        raise node.fail("volume_m3", f"a {kind} must {'sink' if kind == 'weight' else 'float'}"
                                     f" in water; this one has net downward force {net:.3f} N")
    node.done()
    return piece


def _procedure(node: _Node) -> ProcedureLimits:
    p = ProcedureLimits(
        max_tilt_deg=node.number("max_tilt_deg", positive=True),
        max_depth_excursion_m=node.number("max_depth_excursion_m", 1.0, positive=True),
        attitude_tol_deg=node.number("attitude_tol_deg", 1.0, positive=True),
        rate_tol_deg_s=node.number("rate_tol_deg_s", 1.0, positive=True),
        min_steady_s=node.number("min_steady_s", 10.0, positive=True),
        settle_timeout_s=node.number("settle_timeout_s", 120.0, positive=True),
        collect_max_s=node.number("collect_max_s", 120.0, positive=True),
        connect_timeout_s=node.number("connect_timeout_s", 30.0, positive=True),
        link_timeout_s=node.number("link_timeout_s", 0.8, positive=True),
        tilt_rate_deg_s=node.number("tilt_rate_deg_s", 5.0, positive=True),
    )
    if p.max_tilt_deg >= 60:
        raise node.fail("max_tilt_deg", f"expected less than 60 degrees, got {p.max_tilt_deg}")
    for retired in RETIRED_PROCEDURE_KEYS:  # read, so that older recordings still replay
        node.number(retired, 1.0, positive=True)
    node.done()
    return p


def _named(node: _Node, key: str, keys: tuple[str, ...], read: Callable[[_Node, str], float]
           ) -> tuple[float, ...]:
    child = node.child(key)
    values = tuple(read(child, k) for k in keys)
    child.done()
    return values


def parse_profile(data: object, source: str = "<profile>") -> Profile:
    """Validate a profile already parsed from YAML; raise ProfileError on any problem."""
    top = _Node(data, "", source)
    g = top.number("gravity_m_s2", 9.81, positive=True)
    rho = top.number("water_density_kg_m3", 1025.0, positive=True)
    buoy = top.child("buoyancy")
    if buoy.has("force_N") == buoy.has("volume_m3"):
        raise buoy.fail("force_N", "give exactly one of force_N or volume_m3")
    B = (buoy.number("force_N", positive=True) if buoy.has("force_N")
         else rho * g * buoy.number("volume_m3", positive=True))
    r_b = _vec3(buoy, "centre_m")
    buoy.done()

    def mag(n: _Node, k: str) -> float:
        return n.number(k, minimum=0.0)

    def neg(n: _Node, k: str) -> float:
        v = n.number(k)
        if v > 0:
            raise n.fail(k, f"damping derivatives are negative (Fossen's sign), got {v}")
        return v

    added = _named(top, "added_mass", ("surge_kg", "sway_kg", "heave_kg", "roll_kg_m2",
                                       "pitch_kg_m2", "yaw_kg_m2"), mag)
    damping = top.child("damping")
    dofs = ("surge", "sway", "heave", "roll", "pitch", "yaw")
    linear = _named(damping, "linear", dofs, neg)
    quadratic = _named(damping, "quadratic", dofs, neg)
    damping.done()

    curves_node = top.child("thrust_curves")
    curves = {str(k): _thrust_curve(str(k), curves_node.child(str(k))) for k in curves_node.data}
    thrusters = tuple(_thruster(t, curves) for t in top.items("thrusters"))
    channels = [t.channel for t in thrusters]
    if len(set(channels)) != len(channels):
        raise top.fail("thrusters", f"two thrusters share an output channel: {channels}")

    ballast = top.child("ballast")
    slots = []
    for s in ballast.items("slots"):
        slots.append(BallastSlot(s.text("name"), _vec3(s, "position_m"),
                                 s.number("max_weight_kg", minimum=0.0),
                                 s.number("max_float_kg", minimum=0.0)))
        s.done()
    inventory = tuple(_piece(p, rho, g) for p in ballast.items("inventory", []))
    for key, names in (("slots", [s.name for s in slots]),
                       ("inventory", [p.name for p in inventory])):
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ballast.fail(key, f"expected unique names, got {', '.join(twice)} twice")
    window = ballast.vector("net_buoyancy_pct", 2, [0.3, 1.0])
    if not 0 <= window[0] <= window[1]:
        raise ballast.fail("net_buoyancy_pct", f"expected [low, high] with 0 <= low <= high, "
                                               f"got {list(window)}")
    level_tol_deg = ballast.number("level_tol_deg", 0.5, positive=True)
    installed = [_installed(i) for i in ballast.items("installed", [])]
    ballast.done()

    procedure = _procedure(top.child("procedure"))
    holds = []
    for h in top.items("holds", [{"roll_deg": 0, "pitch_deg": 0},
                                 {"roll_deg": 20, "pitch_deg": 20}]):
        hold = HoldSetpoint(h.number("roll_deg"), h.number("pitch_deg"))
        for key, angle in (("roll_deg", hold.roll_deg), ("pitch_deg", hold.pitch_deg)):
            if abs(angle) > procedure.max_tilt_deg:
                raise h.fail(key, f"{angle}° is beyond procedure.max_tilt_deg "
                                  f"({procedure.max_tilt_deg}°)")
        h.done()
        holds.append(hold)
    if len({(h.roll_deg, h.pitch_deg) for h in holds}) < 2 or all(
            h.roll_deg == 0 and h.pitch_deg == 0 for h in holds):
        raise top.fail("holds", "expected at least two holds at different attitudes, one of "
                                "them tilted (z_g is only seen at a tilt), e.g. level and "
                                "roll = pitch = 20°")
    frame = top.raw("frame_config", None)
    if frame is not None and (not isinstance(frame, int) or isinstance(frame, bool)):
        raise top.fail("frame_config", f"expected an ArduSub FRAME_CONFIG number, got {frame!r}")
    holds_station = top.raw("holds_station", False)
    if not isinstance(holds_station, bool):
        raise top.fail("holds_station", f"expected true or false, got {holds_station!r}")
    top.raw("description", "")
    profile = Profile(
        name=top.text("name"), source=source,
        mass_kg=top.number("mass_kg", positive=True), gravity_m_s2=g,
        water_density_kg_m3=rho, buoyancy_N=B, r_b_m=r_b,
        inertia_kg_m2=_vec3(top, "inertia_kg_m2"), added_mass=added,  # type: ignore[arg-type]
        linear_damping=linear, quadratic_damping=quadratic,  # type: ignore[arg-type]
        nominal_voltage_V=top.number("nominal_voltage_V", 16.0, positive=True),
        thrusters=thrusters, slots=tuple(slots), inventory=inventory,
        net_buoyancy_pct=(window[0], window[1]), level_tol_deg=level_tol_deg,
        holds=tuple(holds), procedure=procedure,
        frame_config=frame, holds_station=holds_station,
        attitude_error_deg=top.number("attitude_error_deg", 0.1, minimum=0.0),
    )
    top.done()
    return dataclasses.replace(profile, installed=profile.resolve_installed(
        installed, "ballast.installed"))


def _installed(node: _Node) -> InstalledPiece:
    """One ``ballast.installed`` entry (names are checked against the profile later)."""
    count = node.number("count", minimum=0)
    if count != int(count):
        raise node.fail("count", f"expected a whole number, got {count}")
    item = InstalledPiece(node.text("slot"), node.text("piece"), int(count))
    node.done()
    return item


def shipped_profiles() -> list[str]:
    """Names of the profiles shipped with trimd (package data), e.g. ``bluerov2-heavy``."""
    folder = resources.files("trimd") / "profiles"
    return sorted(f.name.removesuffix(".yaml") for f in folder.iterdir()
                  if f.name.endswith(".yaml"))


def read_profile_text(path: str | Path) -> tuple[str, str]:
    """The YAML text of ``path`` (a file, or a shipped profile's name) and its source name."""
    p = Path(path)
    try:
        if not p.exists() and not p.suffix and str(path) in shipped_profiles():
            resource = resources.files("trimd") / "profiles" / f"{path}.yaml"
            return resource.read_text(encoding="utf-8"), f"{path}.yaml (shipped)"
        return p.read_text(encoding="utf-8"), str(p)
    except OSError as exc:
        hint = (f"; shipped profiles: {', '.join(shipped_profiles())}"
                if not p.suffix and not p.exists() else "")
        raise ProfileError(f"{path}: cannot read profile ({exc.strerror}){hint}") from None


def load_profile(path: str | Path) -> Profile:
    """Load and validate ``path``: a YAML file, or the name of a shipped profile."""
    text, source = read_profile_text(path)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ProfileError(f"{path}: not valid YAML: {exc}") from None
    return parse_profile(data, source)
