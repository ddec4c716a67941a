"""Recording the ballast now installed on a vehicle in its trim history: what
``trimd ballast apply`` and the TUI's "apply" after a trim both do.

The configuration recorded is the proposal carried out on what was installed before (the
history's record for the vehicle, else the profile's ``ballast.installed``), with the
operator's ``edits`` (counts per slot and piece kind) on top. It is written whole, in one
transaction, with its source: ``proposal`` or ``edited``. With the estimate the proposal
was for, the physics check of the recorded configuration comes back too: the passive
trim and net buoyancy it gives (:func:`trimd.ballast.check.check_trim`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from trimd.app.history import History
from trimd.app.history.installed import current_installed
from trimd.ballast.changes import ballast_changes, change_loads
from trimd.ballast.check import SlotLoad, Trim, check_trim
from trimd.ballast.propose import Proposal, propose_ballast
from trimd.core.errors import DataError, ProfileError
from trimd.core.estimate import StaticEstimate
from trimd.core.profile import InstalledPiece, Profile

__all__ = ["Applied", "apply_ballast"]


@dataclass(frozen=True)
class Applied:
    """What was recorded.

    Attributes
    ----------
    vehicle, db : the vehicle's key and the history file.
    source : ``proposal`` (as proposed) or ``edited`` (counts changed by the operator).
    before_from : where the configuration before came from, in words.
    installed : the whole configuration now on the vehicle.
    loads : per slot, what changed from before (for the physics check and the verify
        hold: the estimate measured the vehicle as it was before).
    changes : what the operator moved, removed and added, for people.
    trim : the physics check with the estimate (None without one).
    """

    vehicle: str
    db: Path
    source: Literal["proposal", "edited"]
    before_from: str
    installed: tuple[InstalledPiece, ...]
    loads: tuple[SlotLoad, ...]
    changes: tuple[str, ...]
    trim: Trim | None


def _edited(base: Sequence[InstalledPiece], edits: Sequence[InstalledPiece]
            ) -> list[InstalledPiece]:
    counts = {(x.slot, x.piece): x.count for x in base}
    counts.update({(x.slot, x.piece): x.count for x in edits})
    return [InstalledPiece(s, p, n) for (s, p), n in counts.items()]


def _counts(pieces: Sequence[InstalledPiece]) -> dict[tuple[str, str], int]:
    return {(x.slot, x.piece): x.count for x in pieces if x.count > 0}


def apply_ballast(db: str | Path, vehicle: str, profile: Profile, *,
                  estimate: StaticEstimate | None = None, proposal: Proposal | None = None,
                  edits: Sequence[InstalledPiece] = ()) -> Applied:
    """Record the ballast installed on ``vehicle``: ``proposal`` carried out (default,
    with an ``estimate``: its ``milp`` proposal from what is installed before; neither:
    what is installed before) with ``edits`` on top.

    Raises
    ------
    ProfileError : nothing to record (no estimate, proposal or edit), or an edit or a
        recorded piece the profile does not have.
    DataError : ``proposal`` starts from another configuration than the one recorded now
        (the ballast was recorded again since the trim): nothing is written.
    """
    if estimate is None and proposal is None and not edits:
        raise ProfileError("nothing to record: give the estimate (its proposal is "
                           "recorded) or the counts installed (SLOT:PIECE=COUNT), or both")
    before, where = current_installed(db, vehicle, profile)
    if proposal is None and estimate is not None:
        proposal = propose_ballast(estimate, profile, "milp", installed=before)
    if proposal is not None and _counts(proposal.installed) != _counts(before):
        raise DataError(f"the proposal starts from ballast other than what {where} holds "
                        "now (it was recorded again since the trim): trim again, or record "
                        "the counts installed (trimd ballast apply --set)")
    planned = proposal.installed_after if proposal is not None else before
    source: Literal["edited", "proposal"] = "edited" if edits else "proposal"
    after = profile.resolve_installed(_edited(planned, edits), "the installed ballast")
    loads = change_loads(profile, before, after)
    trim = check_trim(estimate, loads, profile.gravity_m_s2) if estimate is not None else None
    with History(db) as history:
        history.record_installed(vehicle, profile.name, time.time(), source, after)
        path = history.path
    return Applied(vehicle, path, source, where, tuple(after), loads,
                   tuple(c.text for c in ballast_changes(loads)), trim)
