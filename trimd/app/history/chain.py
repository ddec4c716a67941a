"""What ``trimd run --verify`` (and ``trimd float --correct``) checks when given no file,
along the chain trim → apply → verify (or float) → correction → apply → verify.

It is the vehicle's latest trim with a proposal, unless a verify hold's or a float
check's correction recorded since has been carried out: one whose ``installed_after`` is
the ballast installed now (what ``trimd ballast apply`` recorded last). Then it is the
newest such correction: the vehicle as that verify hold (or float check) measured it, and
the correction's pieces. A correction not applied leaves the trim's prediction (or the
previous correction's) in force, as the ballast on the vehicle does.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from trimd.app.history.report import utc_text
from trimd.app.history.store import History
from trimd.core.profile import InstalledPiece

__all__ = ["installed_since_trim", "proposal_on_vehicle"]


def _counts(pieces: Sequence[dict[str, Any]]) -> dict[tuple[str, str], int]:
    return {(str(x["slot"]), str(x["piece"])): int(x["count"]) for x in pieces
            if int(x["count"]) > 0}


def proposal_on_vehicle(history: History, vehicle: str, installed: Sequence[InstalledPiece]
                        ) -> tuple[dict[str, Any], dict[str, Any], str] | None:
    """The estimate and proposal (their JSON dicts) a verify hold of ``vehicle`` checks
    with ``installed`` on it (module docstring), and which record they are, in words; None
    when the history holds no trim with a proposal for it."""
    trims = [t for t in history.trims(vehicle) if t.proposal is not None]
    if not trims:
        return None
    trim = trims[-1]
    assert trim.proposal is not None
    now = {(x.slot, x.piece): x.count for x in installed if x.count > 0}
    applied = [c for c in history.corrections(vehicle) if c.t_unix >= trim.t_unix
               and _counts(c.proposal.get("installed_after", [])) == now]
    if applied:
        c = applied[-1]
        return c.estimate, c.proposal, f"the correction of {vehicle} at {utc_text(c.t_unix)}"
    return trim.estimate, trim.proposal, f"the trim of {vehicle}"


def installed_since_trim(history: History, vehicle: str) -> bool:
    """Has ballast been recorded as installed on ``vehicle`` (``trimd ballast apply``)
    since its latest trim with a proposal? Without such a record a verify hold takes the
    proposal as fitted as proposed."""
    trims = [t for t in history.trims(vehicle) if t.proposal is not None]
    record = history.installed(vehicle)
    return bool(trims) and record is not None and record.t_unix >= trims[-1].t_unix
