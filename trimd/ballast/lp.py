"""The ballast proposal as a (mixed-integer) linear programme, solved lexicographically.

Columns are ballast :class:`Item` amounts u ≥ 0 (ideal kilograms for the continuous
methods, piece counts for ``milp``) plus six slacks [s_x, s_y, b_lo, b_hi, r_x, r_y].
With f the net downward force of one unit [N] at slot position r = (x, y, z) and m the
net moment W·r_g − B·r_b of the estimate, the rows are

* level:  |m_x + Σ f·x·u| ≤ t·(m_z + Σ f·z·u) + s_x + r_x, and the same for y, where
  t = tan(level tolerance). Since tan φ = m_y/m_z and |tan θ| ≤ |m_x|/m_z at the passive
  equilibrium, s = r = 0 guarantees |φ|, |θ| ≤ the tolerance exactly (t = 0: exactly
  level). When no ballast can make m_z positive (no static stability, no passive trim)
  t is 0: the best achievable then balances the moments;
* net-buoyancy window: lo·W′ − b_lo ≤ B′ − W′ ≤ hi·W′ + b_hi (W′, B′ after ballasting);
* capacity: per slot, Σ kilograms of weight ≤ max_weight_kg and Σ kgf of lift ≤ max_float_kg;
* inventory: Σ pieces of a kind ≤ its count.

Ballast already installed (``Profile.installed``, or what ``trimd ballast apply``
recorded): the measured q includes it, so the programme has, besides a column of pieces
added per slot and kind, a column of pieces removed per installed slot and kind
(0 ≤ removed ≤ installed) whose every coefficient is the negative of an added piece's:
removing a piece takes its force, moment and slot use away. Capacity rows count what is
installed; the inventory row of a kind is Σ added − Σ removed ≤ the spare pieces (a piece
taken out of one slot can go into another: a move). The piece count of the objective is
then the number of handling operations Σ_kind max(added, removed), a move (one removal
and one addition of the same kind) counted once, through one auxiliary column per kind
(``h_k ≥ added_k``, ``h_k ≥ removed_k``); the mass term is the net dry mass added.

The ballast objective is kg of weight + kgf of lift for ideal ballast, and for pieces
the count plus their dry mass scaled below one piece (fewest pieces, then least mass).
It is first minimised with the slacks held at zero, one solve when the requirement can
be met; otherwise lexicographically, each optimum held for the next: the window slack
(surfacing on power loss comes first), the level slack (the least residual moment),
the ballast. scipy.optimize.linprog solves the continuous programmes,
scipy.optimize.milp the integer ones.

Why the integer programme needs the free allowance r (0 ≤ r ≤ :data:`ALLOWANCE_SHARE` of
:func:`moment_resolution`) in the lexicographic stages: whole pieces reach only a lattice
of moments, so the least residual moment over the integers is a closest-point problem
whose LP bound is 0 while its optimum is not; branch and bound cannot close that gap, and
the next stage, holding that optimum, is a needle-in-a-haystack search. Residuals well
below what the estimate resolves barely change the chance that the true vehicle is level,
so they are free. Not the whole 1σ where the pieces can aim near level (ballast can make
the vehicle statically stable, and the level band t·m_z plus a quarter is at least
:data:`FINE_LATTICE` of the smallest moment of one piece): with the aim at the tolerance
less 1.96σ, a free 1σ lets the fewest-pieces stage place the prediction where the true
vehicle is off level on that axis one time in six; a quarter, one in twenty-three. Where
they cannot, the band is a needle among the pieces' moments (a quarter took up to 18 s of
CPU per proposal: docs/ballast.md) and the whole 1σ is free. Every integer solve has a budget of
branch-and-bound nodes, no time limit (a replay proposes exactly what the live run did, on
any machine); when it is reached the best solution found is used and the result says so.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from trimd.ballast.check import MIN_GM_M
from trimd.core.estimate import StaticEstimate
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.types import FloatArray

__all__ = ["ALLOWANCE_SHARE", "FINE_LATTICE", "N_SLACK", "Item", "Programme",
           "build_programme", "ideal_items", "moment_resolution", "piece_items"]

#: Slack columns after the items: s_x, s_y, b_lo, b_hi, r_x, r_y (module docstring).
N_SLACK = 6
#: CG shift [m] whose moment W·shift is the least moment resolution (a micrometre).
_MIN_RESOLUTION_M = 1e-6
#: The share of :func:`moment_resolution` the lexicographic stages leave free where the
#: pieces can aim near level (module docstring).
ALLOWANCE_SHARE = 0.25
#: They can when the level band is at least this share of the smallest moment of one piece.
FINE_LATTICE = 0.1


@dataclass(frozen=True)
class Item:
    """One unit of one kind of ballast at one slot: a column of the programme.

    Attributes
    ----------
    slot : index into ``profile.slots``.
    kind : ``"weight"`` or ``"float"``.
    piece : the inventory piece's name; None for ideal ballast (1 unit = 1 kg of
        weight with no volume, or 1 kgf of lift with no mass: the thesis's idealisation).
    mass_kg, buoyancy_N : dry mass [kg] and buoyancy [N] of one unit.
    capacity_kg : what one unit uses of the slot: kg of weight, or kgf of lift.
    cost_kg : what one unit adds to the last objective [kg].
    count : pieces on hand (for a removal: pieces installed there); None for ideal
        ballast (a continuous amount).
    removal : the column takes installed pieces out (every coefficient negated).
    """

    slot: int
    kind: Literal["weight", "float"]
    piece: str | None
    mass_kg: float
    buoyancy_N: float
    capacity_kg: float
    cost_kg: float
    count: int | None = None
    removal: bool = False

    @property
    def sign(self) -> float:
        """+1 for ballast put in, −1 for installed ballast taken out."""
        return -1.0 if self.removal else 1.0


def ideal_items(profile: Profile, *, floats: bool) -> list[Item]:
    """Ideal weights at every slot that takes weight, and floats too if ``floats``."""
    g = profile.gravity_m_s2
    items = [Item(i, "weight", None, 1.0, 0.0, 1.0, 1.0)
             for i, s in enumerate(profile.slots) if s.max_weight_kg > 0]
    if floats:
        items += [Item(i, "float", None, 0.0, g, 1.0, 1.0)
                  for i, s in enumerate(profile.slots) if s.max_float_kg > 0]
    return items


def piece_items(profile: Profile, installed: Sequence[InstalledPiece] = ()) -> list[Item]:
    """Every inventory piece at every slot with room for at least one of it, then a
    removal column for every slot and kind in ``installed`` (names as the profile spells
    them: :meth:`Profile.resolve_installed`). A kind can be added up to its spare count
    plus what is installed of it anywhere (moved)."""
    g, rho = profile.gravity_m_s2, profile.water_density_kg_m3
    mounted = {p.name: sum(x.count for x in installed if x.piece == p.name)
               for p in profile.inventory}
    items = []
    for i, s in enumerate(profile.slots):
        for p in profile.inventory:
            use = p.capacity_kg(rho)
            room = s.max_weight_kg if p.kind == "weight" else s.max_float_kg
            available = p.count + mounted[p.name]
            if available > 0 and use <= room:
                items.append(Item(i, p.kind, p.name, p.mass_kg, rho * g * p.volume_m3, use,
                                  p.mass_kg, available))
    slots = [s.name for s in profile.slots]
    for x in installed:
        p = profile.piece(x.piece)
        items.append(Item(slots.index(x.slot), p.kind, p.name, p.mass_kg,
                          rho * g * p.volume_m3, p.capacity_kg(rho), p.mass_kg, x.count,
                          removal=True))
    return items


@dataclass(frozen=True, eq=False)
class Programme:
    """Rows A·x ≤ b, bounds, integrality and the objectives in priority order.

    ``exact`` is False when the solve with the slacks at zero cannot succeed: no ballast
    within the bounds makes m_z positive (the level rows then only balance the moments,
    t = 0), or whole pieces asked for t = 0 (their moments never balance exactly).
    """

    items: tuple[Item, ...]
    A: FloatArray
    b: FloatArray
    upper: FloatArray
    integrality: NDArray[np.int_]
    objectives: tuple[tuple[str, FloatArray], ...]
    exact: bool


def _moment_arms(items: Sequence[Item], profile: Profile) -> tuple[FloatArray, FloatArray]:
    """Net downward force of one unit of every item [N] and its slot position [m]."""
    f = np.array([it.sign * (it.mass_kg * profile.gravity_m_s2 - it.buoyancy_N)
                  for it in items])
    r = np.array([profile.slots[it.slot].position_m for it in items]).reshape(-1, 3)
    return f, r


def _level_rows(items: Sequence[Item], profile: Profile, m: FloatArray, t: float
                ) -> tuple[list[FloatArray], list[float]]:
    f, r = _moment_arms(items, profile)
    rows, rhs = [], []
    for axis in (0, 1):
        for sign in (1.0, -1.0):
            slack = np.zeros(N_SLACK)
            slack[[axis, 4 + axis]] = -1.0
            rows.append(np.r_[f * (sign * r[:, axis] - t * r[:, 2]), slack])
            rhs.append(t * m[2] - sign * m[axis])
    return rows, rhs


def moment_resolution(estimate: StaticEstimate) -> float:
    """The least net moment [N·m] worth balancing: the estimate's 1σ of m_x and m_y, and
    at least the moment of a micrometre's shift of the centre of gravity."""
    std = np.sqrt(np.clip(np.diag(estimate.q_cov)[1:3], 0.0, None))
    return max(float(std.max()), _MIN_RESOLUTION_M * estimate.weight_N)


def _levelable(estimate: StaticEstimate, items: Sequence[Item], profile: Profile,
               upper: FloatArray) -> bool:
    """Whether some amounts within ``upper`` could make m_z = W·z_g − B·z_b positive."""
    f, r = _moment_arms(items, profile)
    best = float(estimate.q[3]) + float(np.clip(f * r[:, 2], 0.0, None) @ upper)
    return best > MIN_GM_M * estimate.weight_N


def _aims_near_level(items: Sequence[Item], profile: Profile, band_Nm: float,
                     resolution_Nm: float) -> bool:
    """Whether the level band ``band_Nm`` = t·m_z [N·m] plus a quarter of the resolution
    is at least :data:`FINE_LATTICE` of the smallest x/y moment one piece makes [N·m]."""
    f, r = _moment_arms(items, profile)
    moments = np.hypot(f * r[:, 0], f * r[:, 1])
    finest = min((float(m) for m, it in zip(moments, items, strict=True)
                  if m > 0.0 and it.count), default=0.0)
    return band_Nm + ALLOWANCE_SHARE * resolution_Nm >= FINE_LATTICE * finest


def _window_rows(items: Sequence[Item], profile: Profile, estimate: StaticEstimate,
                 window_pct: tuple[float, float]) -> tuple[list[FloatArray], list[float]]:
    g = profile.gravity_m_s2
    f, _ = _moment_arms(items, profile)
    w = np.array([it.sign * it.mass_kg * g for it in items])
    lo, hi = window_pct[0] / 100.0, window_pct[1] / 100.0
    W, q0 = estimate.weight_N, float(estimate.q[0])
    rows = [np.r_[lo * w + f, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0]]
    rhs = [-lo * W - q0]
    if math.isfinite(hi):
        rows.append(np.r_[-f - hi * w, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0])
        rhs.append(q0 + hi * W)
    return rows, rhs


def _limit_rows(items: Sequence[Item], profile: Profile
                ) -> tuple[list[FloatArray], list[float]]:
    rows, rhs = [], []
    for i, s in enumerate(profile.slots):
        for kind, room in (("weight", s.max_weight_kg), ("float", s.max_float_kg)):
            use = np.array([it.sign * it.capacity_kg if (it.slot, it.kind) == (i, kind)
                            else 0.0 for it in items])
            if np.any(use):
                installed = sum(it.capacity_kg * (it.count or 0) for it in items
                                if it.removal and (it.slot, it.kind) == (i, kind))
                rows.append(np.r_[use, np.zeros(N_SLACK)])
                rhs.append(room - installed)
    for p in profile.inventory:
        mine = np.array([it.sign if it.piece == p.name else 0.0 for it in items])
        if np.any(mine):
            rows.append(np.r_[mine, np.zeros(N_SLACK)])
            rhs.append(float(p.count))
    return rows, rhs


def _unit_limit(item: Item, profile: Profile) -> float:
    """Most units of ``item`` its slot takes (and, for a piece, the inventory holds)."""
    s = profile.slots[item.slot]
    room = s.max_weight_kg if item.kind == "weight" else s.max_float_kg
    if item.count is None:
        return room / item.capacity_kg
    if item.removal:
        return float(item.count)
    return float(min(item.count, math.floor(room / item.capacity_kg + 1e-9)))


def build_programme(estimate: StaticEstimate, profile: Profile, items: Sequence[Item], *,
                    level_tol_deg: float, window_pct: tuple[float, float] | None
                    ) -> Programme:
    """The programme for ``items`` (see the module docstring for rows and objectives)."""
    n = len(items)
    units = np.array([_unit_limit(it, profile) for it in items], dtype=float)
    levelable = _levelable(estimate, items, profile, units)
    t = math.tan(math.radians(level_tol_deg)) if levelable else 0.0
    parts = [_level_rows(items, profile, estimate.q[1:], t), _limit_rows(items, profile)]
    if window_pct is not None:
        parts.append(_window_rows(items, profile, estimate, window_pct))
    rows = [row for part in parts for row in part[0]]
    rhs = [v for part in parts for v in part[1]]
    integer = np.array([it.count is not None for it in items] + [False] * N_SLACK, dtype=int)
    resolution = moment_resolution(estimate) if np.any(integer) else 0.0
    if levelable and _aims_near_level(items, profile, t * float(estimate.q[3]), resolution):
        resolution *= ALLOWANCE_SHARE
    upper = np.r_[units, math.inf, math.inf, [math.inf if window_pct is not None else 0.0] * 2,
                  resolution, resolution]
    slack = np.zeros((N_SLACK, n + N_SLACK))
    slack[:, n:] = np.eye(N_SLACK)
    mass = np.r_[[it.sign * it.cost_kg for it in items], np.zeros(N_SLACK)]
    cost = mass
    if np.any(integer):
        # fewest pieces, then least mass: the mass term stays below one piece
        scale = 1.0 + float(np.abs(mass[:n]) @ upper[:n])
        cost = (0.0 if any(it.removal for it in items) else integer) + mass / scale
    A = np.array(rows, dtype=float).reshape(-1, n + N_SLACK)
    b = np.array(rhs, dtype=float)
    objectives = [("net-buoyancy window", slack[2] + slack[3]),
                  ("level", slack[0] + slack[1]), ("ballast", cost)]
    if any(it.removal for it in items):
        A, b, upper, integer, objectives = _with_handling(items, A, b, upper, integer,
                                                          objectives)
    return Programme(tuple(items), A, b, upper, integer, tuple(objectives),
                     levelable and (t > 0 or not np.any(integer)))


def _with_handling(items: Sequence[Item], A: FloatArray, b: FloatArray, upper: FloatArray,
                   integer: NDArray[np.int_], objectives: list[tuple[str, FloatArray]]
                   ) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.int_],
                              list[tuple[str, FloatArray]]]:
    """Append one handling column h_k per piece kind, h_k ≥ Σ added and h_k ≥ Σ removed
    of kind k, and count Σ h_k in the ballast objective: pieces handled, a move once."""
    kinds = sorted({it.piece for it in items if it.piece is not None})
    n, k = len(items), len(kinds)
    rows = []
    for j, kind in enumerate(kinds):
        for removal in (False, True):
            row = np.zeros(n + N_SLACK + k)
            row[:n] = [1.0 if (it.piece, it.removal) == (kind, removal) else 0.0
                       for it in items]
            row[n + N_SLACK + j] = -1.0
            rows.append(row)
    A = np.vstack([np.hstack([A, np.zeros((A.shape[0], k))]), *rows])
    b = np.r_[b, np.zeros(len(rows))]
    handled = [(name, np.r_[c, np.ones(k) if name == "ballast" else np.zeros(k)])
               for name, c in objectives]
    return (A, b, np.r_[upper, np.full(k, math.inf)], np.r_[integer, np.zeros(k, dtype=int)],
            handled)
