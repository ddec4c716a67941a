"""The thesis's geometric ballast method (Elias 2017, §3.2.2; docs/method.md §4, ``line``).

Seen from above, the estimated centre of gravity CG1 lies off CG0. Draw the line from
CG1 through CG0 and continue it until it leaves the polygon of the weight slots; put
the counter-mass that moves the centre of gravity back to CG0 at that point, and split
it between the two slots of that edge by the lever rule. trimd draws the line along
the net moment m = W·r_g − B·r_b instead of r_g (the same direction when the centre of
buoyancy lies on the z axis, and right without that assumption): the counter-mass is
the ideal weight whose moment cancels m_x and m_y. Body frame FRD, metres, kilograms.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from trimd.core.types import FloatArray

__all__ = ["LineSplit", "line_split"]



@dataclass(frozen=True)
class LineSplit:
    """The counter-mass of the line method and its split.

    Attributes
    ----------
    point_m : (x, y) where the counter-mass goes [m].
    mass_kg : the counter-mass [kg] (an ideal weight: mass·g of downward force).
    slots : the indices (i, j) of the two slots of the edge, into the given positions.
    masses_kg : the lever-rule split, (mass at i, mass at j) [kg].
    """

    point_m: tuple[float, float]
    mass_kg: float
    slots: tuple[int, int]
    masses_kg: tuple[float, float]


def line_split(moment_xy_Nm: FloatArray, positions_xy_m: FloatArray,
               gravity_m_s2: float) -> LineSplit | None:
    """Counter-mass on the slot polygon opposite the net moment ``(m_x, m_y)`` [N·m].

    ``positions_xy_m`` is (n, 2): the weight slots seen from above. The ray from CG0
    along −(m_x, m_y) is intersected with the segment between every two slots and the
    farthest hit is taken: on the convex hull of the slots, hence the least mass. None
    when the ray meets no segment (no slot pair lies opposite the centre of gravity) or
    the moment is zero.

    Examples
    --------
    >>> s = line_split(np.array([-1.0, -1.0]), np.array([[1.0, 0.0], [0.0, 1.0]]), 1.0)
    >>> np.round(s.point_m, 9).tolist(), round(s.mass_kg, 9), np.round(s.masses_kg, 9).tolist()
    ([0.5, 0.5], 2.0, [1.0, 1.0])
    """
    norm = float(np.hypot(*moment_xy_Nm))
    if norm == 0.0:
        return None
    d = -np.asarray(moment_xy_Nm, float) / norm
    best: tuple[float, float, int, int] | None = None
    for i, j in itertools.combinations(range(len(positions_xy_m)), 2):
        p, e = positions_xy_m[i], positions_xy_m[j] - positions_xy_m[i]
        M = np.column_stack([d, -e])
        if abs(np.linalg.det(M)) < 1e-12 * max(1.0, float(np.dot(e, e))):
            continue
        t, s = np.linalg.solve(M, p)
        if t > 1e-12 and -1e-12 <= s <= 1 + 1e-12 and (best is None or t > best[0]):
            best = (float(t), float(np.clip(s, 0.0, 1.0)), i, j)
    if best is None:
        return None
    t, s, i, j = best
    mass = norm / (gravity_m_s2 * t)
    point = t * d
    return LineSplit((float(point[0]), float(point[1])), mass, (i, j),
                     ((1 - s) * mass, s * mass))
