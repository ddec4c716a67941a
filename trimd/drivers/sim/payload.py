"""The simulated vehicle's hidden payload and the mass properties it results in.

Syntax of a payload (``--payload`` and the ``payload=`` option of a ``sim:`` link): one or
more items joined by ``+``, each ``KG@WHERE``:

* ``KG`` is the mass added [kg]; a negative number is a float of that lift
  [kilograms-force] (buoyant material of negligible mass);
* ``WHERE`` is the name of a ballast slot of the profile (``10@AftSB``, case-insensitive)
  or a body position in metres ``x,y,z`` (FRD, origin CG0: ``3.5@0.2,-0.1,0.05``).

Examples: ``10@AftSB``, ``0.4@W-aft-ctr``, ``10@AftSB+-2@FrontP``.

Weights are point masses (their own volume is neglected: the displaced water of a lead
block is part of its in-water weight, which is what a ballast table gives); floats are
point buoyancies. The result is the truth the estimator must find, never shown to it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from trimd.core.errors import ProfileError
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

__all__ = ["MassProperties", "PayloadItem", "mass_properties", "parse_payload"]


_ITEM = re.compile(r"^\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)\s*@\s*(.+?)\s*$")


@dataclass(frozen=True, slots=True)
class PayloadItem:
    """One hidden item: ``mass_kg`` > 0 a weight, < 0 a float of that lift [kgf]; at
    ``position_m`` (body FRD, origin CG0); ``label`` as the user wrote it."""

    mass_kg: float
    position_m: tuple[float, float, float]
    label: str


def parse_payload(text: str, profile: Profile) -> tuple[PayloadItem, ...]:
    """Parse a payload description (module docstring); ``""`` is no payload.

    Raises
    ------
    ProfileError
        For a malformed item or a slot the profile does not have.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("sabertooth-dh2")
    >>> parse_payload("10@AftSB", p)[0].position_m
    (-1.031, 0.6, 0.0)
    >>> parse_payload("3.5@0.2,-0.1,0.05+-2@FrontP", p)[1].mass_kg
    -2.0
    """
    items = []
    for part in _split_items(text):
        match = _ITEM.match(part)
        if match is None:
            raise ProfileError(f"payload '{part}': expected KG@SLOT or KG@x,y,z "
                               "(e.g. 10@AftSB, 3.5@0.2,-0.1,0.05)")
        kg, where = float(match.group(1)), match.group(2)
        if not math.isfinite(kg) or kg == 0.0:
            raise ProfileError(f"payload '{part}': expected a non-zero mass in kg")
        items.append(PayloadItem(kg, _position(where, profile, part), part.strip()))
    return tuple(items)


def _split_items(text: str) -> list[str]:
    """Split on the ``+`` that joins items (not the sign of a number: ``+-2``, ``1e+3``)."""
    parts, start = [], 0
    for i, c in enumerate(text):
        if c == "+" and i > start and text[i - 1] not in "eE@,+":
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p for p in parts if p.strip()]


def _position(where: str, profile: Profile, part: str) -> tuple[float, float, float]:
    fields = where.split(",")
    if len(fields) == 3:
        try:
            x, y, z = (float(f) for f in fields)
        except ValueError:
            pass
        else:
            return (x, y, z)
    if len(fields) != 1:
        raise ProfileError(f"payload '{part}': a body position is x,y,z in metres")
    return profile.slot(where).position_m


@dataclass(frozen=True, slots=True)
class MassProperties:
    """True mass properties of the vehicle with its payload (body FRD, origin CG0).

    Attributes
    ----------
    mass_kg : total mass m [kg] (nominal vehicle plus weights).
    W, B : weight and buoyancy [N].
    r_g, r_b : centres of gravity and buoyancy [m].
    inertia_o : rigid-body inertia about the origin CG0 [kg·m²], 3 × 3.
    """

    mass_kg: float
    W: float
    B: float
    r_g: FloatArray
    r_b: FloatArray
    inertia_o: FloatArray

    @property
    def net(self) -> FloatArray:
        """q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] [N, N·m]: what a static
        measurement determines (``trimd.core.model.restoring_matrix``)."""
        return np.concatenate([[self.W - self.B], self.W * self.r_g - self.B * self.r_b])


def mass_properties(profile: Profile, payload: tuple[PayloadItem, ...] = ()
                    ) -> MassProperties:
    """Combine the nominal vehicle with point weights and floats (multi-body centre of mass;
    parallel-axis theorem for the inertia of each weight about CG0).

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("sabertooth-dh2")
    >>> mp = mass_properties(p, parse_payload("10@AftSB", p))
    >>> [round(float(v), 4) for v in mp.r_g]   # docs/method.md §3: x_g ≈ -8.6 mm, y_g ≈ 5.0 mm
    [-0.0086, 0.005, 0.0]
    """
    g = profile.gravity_m_s2
    m = profile.mass_kg
    moment = np.zeros(3)
    B = profile.buoyancy_N
    b_moment = B * np.asarray(profile.r_b_m, float)
    inertia = np.diag(np.asarray(profile.inertia_kg_m2, float))
    for item in payload:
        r = np.asarray(item.position_m, float)
        if item.mass_kg > 0:
            m += item.mass_kg
            moment = moment + item.mass_kg * r
            inertia = inertia + item.mass_kg * (float(r @ r) * np.eye(3) - np.outer(r, r))
        else:
            lift = -item.mass_kg * g
            B += lift
            b_moment = b_moment + lift * r
    return MassProperties(mass_kg=m, W=m * g, B=B, r_g=moment / m, r_b=b_moment / B,
                          inertia_o=inertia)
