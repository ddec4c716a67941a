"""A ballast proposal (:class:`Proposal`, what :func:`trimd.ballast.propose.propose_ballast`
gives) and its JSON shape (:func:`proposal_to_dict`, the ``trimd ballast --json`` one)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from trimd.ballast.changes import Change, ballast_changes, installed_after
from trimd.ballast.check import SlotLoad, Trim
from trimd.core.jsonsafe import json_number
from trimd.core.profile import InstalledPiece

__all__ = ["Proposal", "proposal_to_dict", "slot_to_dict"]


@dataclass(frozen=True, eq=False)
class Proposal:
    """A ballast proposal and its physics check (scipy OptimizeResult-like).

    Attributes
    ----------
    method : ``lp``, ``line``, ``general`` or ``milp``.
    success : False only when the solver itself failed (then nothing is proposed).
    feasible : the proposal meets the method's requirement: level (within
        ``level_tol_deg``) and net buoyancy inside ``window_pct`` where enforced.
    message : a plain statement of the result, and of what limits it when not feasible.
    binding : the limits that are active (a full slot, a used-up piece, a window edge)
        or, when the vehicle cannot be levelled and none is, the cause.
    slots : what goes in every slot of the profile, in profile order.
    trim : the vehicle with the ballast added (combined W, B, centres, passive attitude).
    level_tol_deg : the level requirement (0: exactly level).
    window_pct : the enforced net-buoyancy window [% of weight], None when not enforced.
    installed : the ballast on the vehicle when it was measured (``milp`` starts from it;
        the other methods only add).
    """

    method: str
    success: bool
    feasible: bool
    message: str
    binding: tuple[str, ...]
    slots: tuple[SlotLoad, ...]
    trim: Trim
    level_tol_deg: float
    window_pct: tuple[float, float] | None
    installed: tuple[InstalledPiece, ...] = ()

    @property
    def added_mass_kg(self) -> float:
        """Dry mass of everything added less everything removed [kg]."""
        return sum(s.mass_kg for s in self.slots)

    @property
    def changes(self) -> tuple[Change, ...]:
        """What to move, remove and add, in that order."""
        return ballast_changes(self.slots)

    @property
    def pieces_handled(self) -> int:
        """Pieces the operator handles: each moved, removed or added piece once."""
        return sum(c.count for c in self.changes)

    @property
    def installed_after(self) -> tuple[InstalledPiece, ...]:
        """The ballast on the vehicle once the proposal is carried out."""
        return installed_after(self.installed, self.slots)

    @property
    def trim_std_deg(self) -> tuple[float, float]:
        """1σ of the predicted passive (roll, pitch) [deg] from the estimate's covariance."""
        return (self.trim.roll_std_deg, self.trim.pitch_std_deg)



def _pieces(pieces: Sequence[InstalledPiece]) -> list[dict[str, Any]]:
    return [{"slot": x.slot, "piece": x.piece, "count": x.count} for x in pieces]


def slot_to_dict(s: SlotLoad) -> dict[str, Any]:
    """One slot's load as a proposal's JSON carries it (read back by
    :func:`trimd.app.files.installed_from_json`)."""
    return {"name": s.name, "position_m": list(s.position_m), "weight_kg": s.weight_kg,
            "float_kg": s.float_kg, "mass_kg": s.mass_kg, "pieces": dict(s.pieces),
            "removed": dict(s.removed), "net_down_N": s.net_down_N}


def proposal_to_dict(p: Proposal) -> dict[str, Any]:
    """JSON-ready dict (the ``trimd ballast --json`` shape; units in the key names).

    ``predicted_trim_std_deg`` is [roll, pitch] 1σ; a slot's ``pieces`` maps piece name to
    the count added, ``removed`` to the count taken out; ``changes`` says what to move,
    remove and add; ``installed_before``/``installed_after`` are the configurations.
    A number that is undefined (the passive trim of a vehicle without static stability)
    or unbounded (the window's upper edge for ``general``) is None (JSON ``null``): the
    dict never holds NaN or infinity.
    """
    t = p.trim
    return {
        "method": p.method,
        "slots": [slot_to_dict(s) for s in p.slots],
        "added_mass_kg": p.added_mass_kg,
        "changes": [{"action": c.action, "piece": c.piece, "count": c.count,
                     "from_slot": c.from_slot, "to_slot": c.to_slot, "text": c.text}
                    for c in p.changes],
        "pieces_handled": p.pieces_handled,
        "installed_before": _pieces(p.installed),
        "installed_after": _pieces(p.installed_after),
        "net_buoyancy_N": t.net_buoyancy_N,
        "net_buoyancy_pct": t.net_buoyancy_pct,
        "net_buoyancy_std_N": t.net_buoyancy_std_N,
        "predicted_roll_deg": json_number(t.roll_deg),
        "predicted_pitch_deg": json_number(t.pitch_deg),
        "predicted_trim_std_deg": [json_number(v) for v in p.trim_std_deg],
        "weight_N": t.weight_N,
        "buoyancy_N": t.buoyancy_N,
        "cg_m": t.r_g_m.tolist(),
        "cb_m": t.r_b_m.tolist(),
        "net_moment_Nm": t.net_moment_Nm.tolist(),
        "level_tol_deg": p.level_tol_deg,
        "net_buoyancy_window_pct": (None if p.window_pct is None
                                    else [json_number(v) for v in p.window_pct]),
        "feasible": p.feasible,
        "success": p.success,
        "binding": list(p.binding),
        "message": p.message,
    }


