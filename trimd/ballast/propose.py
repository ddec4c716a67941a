"""Ballast proposal: what to put in which slot so the vehicle floats level, unpowered.

Four methods (docs/method.md §4, ``docs/ballast.md``), all working from the net quantities
the measurement determines, q = [W − B, W·r_g − B·r_b]:

* ``lp`` — ideal weights only, least added mass, exactly level (thesis eq. 3.4/3.5);
* ``line`` — the thesis's geometric method (:mod:`trimd.ballast.line`);
* ``general`` — ideal weights and floats, slot limits, buoyancy ≥ weight (eq. 3.6/3.7);
* ``milp`` — the profile's real pieces, slot capacities, inventory counts, the
  net-buoyancy window; level within a tolerance with the fewest pieces, then the least
  added mass (:mod:`trimd.ballast.lp`). The pieces aim inside the tolerance by the
  estimate's 95 % interval of the trim, so that the TRUE vehicle ends within it. It
  starts from the ballast installed (the profile's ``ballast.installed``, or what
  ``trimd ballast apply`` recorded) and may remove or move pieces: fewest pieces
  handled, a move counted once (:mod:`trimd.ballast.changes` says what to do in words).

When the requirement cannot be met the proposal is the best achievable one (the window
first, then the least residual moment) with ``feasible`` False and the limits that bind
named. Every proposal is checked by physics (:mod:`trimd.ballast.check`): combined
weight, buoyancy and centres, and the passive equilibrium attitude with its uncertainty.
A vehicle left without static stability (W·z_g − B·z_b ≤ 0) has no passive trim: its
angles are NaN in the proposal, ``null`` in
:func:`~trimd.ballast.proposal.proposal_to_dict`, and ``binding``
says so. ``milp`` has a time limit; when it is reached the best solution found is used
and the message says so.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from trimd.ballast.check import SlotLoad, Trim, check_trim
from trimd.ballast.line import line_split
from trimd.ballast.lp import Item, build_programme, ideal_items, moment_resolution, piece_items
from trimd.ballast.proposal import Proposal, proposal_to_dict, slot_to_dict
from trimd.ballast.stages import STAGE_NODES, solve_programme
from trimd.core.errors import DataError, ProfileError
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import covariance_problem
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.types import FloatArray

__all__ = [
    "METHODS",
    "Proposal",
    "SlotLoad",
    "Trim",
    "proposal_to_dict",
    "propose_ballast",
    "slot_to_dict",
]

METHODS = ("lp", "line", "general", "milp")
#: Angle [rad] within which a continuous proposal counts as exactly level (solver tolerance).
_EXACT_RAD = 1e-6
#: Two-sided 95 % quantile of the normal distribution.
_Z95 = 1.959964


def _setup(method: str, profile: Profile, level_tol_deg: float,
           installed: Sequence[InstalledPiece]
           ) -> tuple[list[Item], float, tuple[float, float] | None]:
    """Items, level tolerance [deg] and net-buoyancy window [%] of a method."""
    if method in ("lp", "line"):
        return ideal_items(profile, floats=False), 0.0, None
    if method == "general":
        return ideal_items(profile, floats=True), 0.0, (0.0, math.inf)
    if method == "milp":
        return piece_items(profile, installed), level_tol_deg, profile.net_buoyancy_pct
    raise ValueError(f"unknown ballast method {method!r} (methods: {', '.join(METHODS)})")


def _aim_deg(estimate: StaticEstimate, level_tol_deg: float) -> float:
    """The passive roll and pitch [deg] the pieces should leave so that the true vehicle
    is within ``level_tol_deg`` at 95 %: the tolerance less 1.96σ of the estimate's trim
    (σ(W·y_g − B·y_b) and σ(W·x_g − B·x_b) over the stiffness W·z_g − B·z_b), at least 0
    (then as level as the pieces allow). The estimate's error does not shrink with the
    pieces, so a proposal that spends the whole tolerance on its discreteness leaves the
    true vehicle beyond it about half the time the estimate is off by 1σ."""
    k = float(estimate.q[3])
    if level_tol_deg <= 0 or k <= 0:
        return level_tol_deg
    sigma = np.sqrt(np.clip(np.diag(estimate.q_cov)[1:3], 0.0, None)) / k
    return max(0.0, level_tol_deg - _Z95 * math.degrees(float(sigma.max())))


def _check_inputs(estimate: StaticEstimate, profile: Profile) -> None:
    """DataError for a non-finite estimate, a non-positive weight or a covariance that is
    not one; ProfileError for another vehicle's estimate."""
    if not (np.all(np.isfinite(estimate.q)) and np.all(np.isfinite(estimate.q_cov))):
        raise DataError("the estimate's net force, moments or covariance are not finite")
    if not estimate.weight_N > 0:
        raise DataError(f"the estimate's weight must be positive, got {estimate.weight_N} N")
    problem = covariance_problem(np.asarray(estimate.q_cov, dtype=float))
    if problem is not None:
        raise DataError(f"the estimate's covariance of the net quantities {problem}")
    same = (math.isclose(estimate.buoyancy_N, profile.buoyancy_N, rel_tol=1e-6)
            and math.isclose(estimate.gravity_m_s2, profile.gravity_m_s2, rel_tol=1e-9)
            and np.allclose(estimate.r_b_m, profile.r_b_m, rtol=0.0, atol=1e-9))
    if not same:
        raise ProfileError(
            f"{profile.source}: the estimate was solved with B = {estimate.buoyancy_N:.2f} N at "
            f"r_b = {np.round(estimate.r_b_m, 4).tolist()} m, g = {estimate.gravity_m_s2}; "
            f"profile '{profile.name}' has B = {profile.buoyancy_N:.2f} N at r_b = "
            f"{list(profile.r_b_m)} m, g = {profile.gravity_m_s2}: wrong profile?")


def _line_amounts(estimate: StaticEstimate, profile: Profile, items: list[Item]
                  ) -> tuple[FloatArray | None, str]:
    """Item amounts of the line method, or None and why it cannot be used."""
    amounts = np.zeros(len(items))
    xy = np.array([profile.slots[it.slot].position_m[:2] for it in items]).reshape(-1, 2)
    split = line_split(estimate.q[1:3], xy, profile.gravity_m_s2)
    if split is None:
        if np.hypot(*estimate.q[1:3]) == 0.0:
            return amounts, ""
        return None, ("line: no segment between two weight slots lies opposite the centre of "
                      "gravity; best weights-only proposal (as lp) instead. ")
    for k, kg in zip(split.slots, split.masses_kg, strict=True):
        room = profile.slots[items[k].slot].max_weight_kg
        if kg > room * (1 + 1e-9):
            return None, (f"line: the lever rule needs {kg:.3f} kg at "
                          f"{profile.slots[items[k].slot].name} (capacity {room:g} kg); best "
                          "weights-only proposal (as lp) instead. ")
        amounts[k] = kg
    return amounts, ""


def _slot_loads(profile: Profile, items: list[Item], amounts: FloatArray
                ) -> tuple[SlotLoad, ...]:
    g = profile.gravity_m_s2
    loads = []
    for i, s in enumerate(profile.slots):
        mine = [(it, it.sign * float(u)) for it, u in zip(items, amounts, strict=True)
                if it.slot == i]
        mass = sum(it.mass_kg * u for it, u in mine)
        buoyancy = sum(it.buoyancy_N * u for it, u in mine)
        loads.append(SlotLoad(
            s.name, s.position_m,
            weight_kg=sum(it.capacity_kg * u for it, u in mine if it.kind == "weight"),
            float_kg=sum(it.capacity_kg * u for it, u in mine if it.kind == "float"),
            mass_kg=mass, buoyancy_N=buoyancy, net_down_N=mass * g - buoyancy,
            pieces=tuple((it.piece, round(u)) for it, u in mine
                         if it.piece is not None and u > 0),
            removed=tuple((it.piece, round(-u)) for it, u in mine
                          if it.piece is not None and u < 0)))
    return tuple(loads)


def _active_limits(profile: Profile, items: list[Item], amounts: FloatArray) -> list[str]:
    """Slot capacities with no room left for another unit, and used-up inventory."""
    out = []
    for i, s in enumerate(profile.slots):
        for kind, room, unit in (("weight", s.max_weight_kg, "kg"),
                                 ("float", s.max_float_kg, "kgf")):
            mine = [(it, u) for it, u in zip(items, amounts, strict=True)
                    if (it.slot, it.kind) == (i, kind)]
            if not mine:
                continue
            step = min(it.capacity_kg if it.count is not None else 1e-6 for it, _ in mine)
            installed = sum(it.capacity_kg * (it.count or 0) for it, _ in mine if it.removal)
            if room - installed - sum(it.sign * it.capacity_kg * u for it, u in mine) < (
                    step - 1e-9):
                out.append(f"{s.name} {kind} capacity ({room:g} {unit})")
    for p in profile.inventory:
        used = sum(it.sign * u for it, u in zip(items, amounts, strict=True)
                   if it.piece == p.name)
        if p.count > 0 and used >= p.count:
            out.append(f"inventory: all {p.count} × {p.name} used")
    return out


def _window_state(trim: Trim, window: tuple[float, float] | None) -> tuple[bool, list[str]]:
    """Whether the net buoyancy is inside the window, and the edges that bind."""
    if window is None:
        return True, []
    pct, (lo, hi) = trim.net_buoyancy_pct, window
    low = "buoyancy ≥ weight" if lo == 0 and math.isinf(hi) else f"net buoyancy ≥ {lo:g} %"
    edges = [name for name, hit in ((low, pct <= lo + 1e-6), (f"net buoyancy ≤ {hi:g} %",
                                                             pct >= hi - 1e-6)) if hit]
    return lo - 1e-6 <= pct <= hi + 1e-6, edges


def _unstable(trim: Trim) -> str:
    """The plain statement for a vehicle left without static stability."""
    return (f"no static stability: W·z_g − B·z_b = {trim.net_moment_Nm[2]:.3g} N·m ≤ 0 after "
            "ballast (the centre of gravity is not below the centre of buoyancy): the vehicle "
            "would capsize; passive trim undefined")


def _level_cause(method: str, trim: Trim, items: list[Item], level_tol_deg: float,
                 resolution_Nm: float) -> str:
    """Why the vehicle cannot be levelled when no slot, piece or window limit is active."""
    if not items:
        return "no slot takes the ballast this method uses"
    if method in ("lp", "line"):
        return "weights only: the counter-moment needs weight where no slot is (or a float)"
    band = math.tan(math.radians(level_tol_deg)) * trim.net_moment_Nm[2]
    if method == "milp" and band < resolution_Nm:
        return (f"little static stability: W·z_g − B·z_b = {trim.net_moment_Nm[2]:.3g} N·m, so "
                f"{level_tol_deg:g}° needs the moments balanced to {band:.2g} N·m, finer than "
                f"the estimate resolves ({resolution_Nm:.2g} N·m)")
    if method == "milp":
        return "piece sizes: no combination of the inventory's pieces levels closer"
    return "slot positions: no slot combination gives the counter-moment"


def _attitude_text(trim: Trim) -> str:
    """Passive roll and pitch with their 1σ [deg], or why they are undefined."""
    if not trim.stable:
        return "passive roll and pitch undefined (no static stability)"
    return (f"passive roll {trim.roll_deg:+.3f}° ± {trim.roll_std_deg:.3f}°, pitch "
            f"{trim.pitch_deg:+.3f}° ± {trim.pitch_std_deg:.3f}°")


def _assess(method: str, estimate: StaticEstimate, profile: Profile, items: list[Item],
            amounts: FloatArray, level_tol_deg: float, window: tuple[float, float] | None,
            installed: tuple[InstalledPiece, ...], note: str = "", success: bool = True
            ) -> Proposal:
    """Physics check, feasibility, binding limits and the message of a proposal."""
    loads = _slot_loads(profile, items, amounts)
    trim = check_trim(estimate, loads, profile.gravity_m_s2)
    m = trim.net_moment_Nm
    t = math.tan(math.radians(level_tol_deg)) + _EXACT_RAD
    level = trim.stable and bool(max(abs(m[0]), abs(m[1])) <= t * m[2])
    in_window, edges = _window_state(trim, window)
    binding = ([] if trim.stable else [_unstable(trim)]) + _active_limits(
        profile, items, amounts) + edges
    if not level and not binding:
        binding.append(_level_cause(method, trim, items, level_tol_deg,
                                    moment_resolution(estimate)))
    feasible = success and level and in_window
    result = (f"{_attitude_text(trim)}, net buoyancy {trim.net_buoyancy_N:+.2f} N "
              f"({trim.net_buoyancy_pct:+.2f} % of weight)")
    if feasible:
        message = f"{note}{method}: {result}"
    else:
        unmet = [w for w, ok in (("level", level), ("the net-buoyancy window", in_window))
                 if not ok]
        message = (f"{note}{method}: cannot meet {' and '.join(unmet) or 'the requirement'}; "
                   f"best achievable: {result}; limited by: {'; '.join(binding)}")
    return Proposal(method, success, feasible, message, tuple(binding), loads, trim,
                    level_tol_deg, window, installed)


def propose_ballast(estimate: StaticEstimate, profile: Profile, method: str = "milp", *,
                    level_tol_deg: float | None = None, node_limit: int = STAGE_NODES,
                    installed: Sequence[InstalledPiece] | None = None) -> Proposal:
    """Propose ballast for ``estimate`` on ``profile`` by ``method`` (see :data:`METHODS`).

    Parameters
    ----------
    estimate : the static estimate (its net quantities q and covariance q_cov are used).
    profile : the vehicle the estimate was made on: slots, inventory, window.
    method : ``lp``, ``line``, ``general`` or ``milp``.
    level_tol_deg : for ``milp``, the largest passive roll or pitch accepted [deg]
        (default: the profile's ``level_tol_deg``); the continuous methods level exactly.
    node_limit : the integer solver's branch-and-bound budget per stage; when reached, the
        best solution found is proposed and the message says so (nothing is proposed if
        none was found). A node budget, not a time limit: the same proposal on any machine.
    installed : the ballast on the vehicle when the estimate was measured (default: the
        profile's ``ballast.installed``); ``milp`` may remove or move it, the continuous
        methods only add.

    Returns
    -------
    Proposal : never raises for infeasible or degenerate physics: the best achievable
        proposal comes back with ``feasible`` False and the binding limits named (a
        vehicle without static stability among them, its passive angles NaN).

    Raises
    ------
    ValueError : unknown method.  DataError : non-finite estimate, weight ≤ 0, or a
        covariance that is not symmetric positive semi-definite.
    ProfileError : the estimate was made with another profile's buoyancy or gravity, or
        ``installed`` names a slot or piece the profile does not have.
    """
    mounted = profile.resolve_installed(profile.installed if installed is None
                                        else installed, "installed ballast")
    items, tol, window = _setup(method, profile, profile.level_tol_deg
                                if level_tol_deg is None else level_tol_deg, mounted)
    _check_inputs(estimate, profile)
    note, amounts = "", None
    if method == "line":
        amounts, note = _line_amounts(estimate, profile, items)
    if amounts is not None:
        return _assess(method, estimate, profile, items, amounts, tol, window, mounted, note)
    # aim inside the tolerance first; when the pieces cannot meet the tolerance that way
    # (aiming at 0 leaves them only as level as the moment resolution), at the tolerance
    best: Proposal | None = None
    for target in dict.fromkeys((_aim_deg(estimate, tol), tol)):
        prog = build_programme(estimate, profile, items, level_tol_deg=target,
                               window_pct=window)
        sol = solve_programme(prog, node_limit=node_limit)
        if not sol.success:
            return best or _assess(method, estimate, profile, items, sol.amounts, tol, window,
                                   mounted, f"{sol.message}; nothing proposed. ",
                                   success=False)
        best = _assess(method, estimate, profile, items, sol.amounts, tol, window, mounted,
                       note + (f"{sol.note}. " if sol.note else ""))
        if best.feasible:
            break
    assert best is not None
    return best
