"""What the operator does to go from the installed ballast to a proposal's: the pieces to
move, remove and add, in words ("move 1 × lead-200g from W-aft-ctr to W-front-ctr").

A proposal's slot loads say per slot how many pieces of each kind go in and come out;
pieces of one kind that come out of one slot and go into another are a move (one
handling of each piece), the rest are removed (back to the spares) or added (from them).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from trimd.ballast.check import SlotLoad
from trimd.core.profile import InstalledPiece, Profile

__all__ = ["Change", "ballast_changes", "change_loads", "installed_after"]


@dataclass(frozen=True)
class Change:
    """``count`` pieces of kind ``piece`` moved (``from_slot`` → ``to_slot``), removed
    (from ``from_slot``) or added (to ``to_slot``)."""

    action: Literal["move", "remove", "add"]
    piece: str
    count: int
    from_slot: str | None
    to_slot: str | None

    @property
    def text(self) -> str:
        """The instruction, e.g. ``move 1 × lead-200g from W-aft-ctr to W-front-ctr``."""
        what = f"{self.action} {self.count} × {self.piece}"
        if self.action == "move":
            return f"{what} from {self.from_slot} to {self.to_slot}"
        return f"{what} from {self.from_slot}" if self.action == "remove" else (
            f"{what} to {self.to_slot}")


def ballast_changes(loads: Sequence[SlotLoad]) -> tuple[Change, ...]:
    """The moves, then removals, then additions that realise ``loads`` (slot order): per
    kind, pieces taken out are paired with pieces put in, first slot with first slot."""
    kinds = list(dict.fromkeys(name for s in loads for name, _ in (*s.removed, *s.pieces)))
    moves: list[Change] = []
    rest: list[Change] = []
    for kind in kinds:
        out = [(s.name, n) for s in loads for name, n in s.removed if name == kind and n > 0]
        into = [(s.name, n) for s in loads for name, n in s.pieces if name == kind and n > 0]
        while out and into:
            (source, n_out), (target, n_in) = out[0], into[0]
            k = min(n_out, n_in)
            moves.append(Change("move", kind, k, source, target))
            out = ([(source, n_out - k)] if n_out > k else []) + out[1:]
            into = ([(target, n_in - k)] if n_in > k else []) + into[1:]
        rest += [Change("remove", kind, n, slot, None) for slot, n in out]
        rest += [Change("add", kind, n, None, slot) for slot, n in into]
    return tuple(moves + sorted(rest, key=lambda c: c.action != "remove"))


def installed_after(before: Sequence[InstalledPiece], loads: Sequence[SlotLoad]
                    ) -> tuple[InstalledPiece, ...]:
    """The configuration once ``loads`` are carried out on ``before`` (slot order)."""
    count = {(p.slot, p.piece): p.count for p in before}
    for s in loads:
        for name, n in s.pieces:
            count[(s.name, name)] = count.get((s.name, name), 0) + n
        for name, n in s.removed:
            count[(s.name, name)] = count.get((s.name, name), 0) - n
    order = {s.name: i for i, s in enumerate(loads)}
    return tuple(InstalledPiece(slot, piece, n) for (slot, piece), n in
                 sorted(count.items(), key=lambda kv: (order.get(kv[0][0], -1), kv[0][1]))
                 if n > 0)


def change_loads(profile: Profile, before: Sequence[InstalledPiece],
                 after: Sequence[InstalledPiece]) -> tuple[SlotLoad, ...]:
    """The slot loads that take ``before`` to ``after`` (both checked against ``profile``),
    for :func:`trimd.ballast.check.check_trim`: the physics of a configuration the
    operator edited."""
    g, rho = profile.gravity_m_s2, profile.water_density_kg_m3
    old = {(x.slot, x.piece): x.count for x in before}
    new = {(x.slot, x.piece): x.count for x in after}
    loads = []
    for s in profile.slots:
        delta = {p.name: new.get((s.name, p.name), 0) - old.get((s.name, p.name), 0)
                 for p in profile.inventory}
        kinds = {p.name: p for p in profile.inventory}
        mass = sum(n * kinds[k].mass_kg for k, n in delta.items())
        buoyancy = sum(n * rho * g * kinds[k].volume_m3 for k, n in delta.items())
        loads.append(SlotLoad(
            s.name, s.position_m,
            weight_kg=sum(n * kinds[k].capacity_kg(rho) for k, n in delta.items()
                          if kinds[k].kind == "weight"),
            float_kg=sum(n * kinds[k].capacity_kg(rho) for k, n in delta.items()
                         if kinds[k].kind == "float"),
            mass_kg=mass, buoyancy_N=buoyancy, net_down_N=mass * g - buoyancy,
            pieces=tuple((k, n) for k, n in delta.items() if n > 0),
            removed=tuple((k, -n) for k, n in delta.items() if n < 0)))
    return tuple(loads)
