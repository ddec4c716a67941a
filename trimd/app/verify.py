"""What a verify hold checks (:class:`VerifyTarget`) and the procedure that checks it.

The *verify target* is the trim being verified: its estimate and the ballast installed
since, per slot. Its JSON document (:meth:`VerifyTarget.to_dict`: ``estimate_to_dict`` and
``{"proposal": {"slots": [...]}}``, the shape of a proposal's slots, what
:func:`trimd.app.files.installed_from_json` reads) is what the session recording carries
(:class:`trimd.logs.recorder.TlogRecorder`). A live verify hold is built from that document
read back, not from the objects it was written from, so a replay of the recording builds
the very same procedure and reproduces the verdict.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Never

from trimd.app.files import installed_from_json, read_estimate, read_installed
from trimd.app.history import History
from trimd.app.history.chain import installed_since_trim, proposal_on_vehicle
from trimd.ballast.changes import change_loads
from trimd.ballast.check import SlotLoad
from trimd.ballast.proposal import slot_to_dict
from trimd.ballast.verify import Verification, verify_hold
from trimd.core.errors import DataError, UsageError
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import estimate_from_dict, estimate_to_dict
from trimd.core.procedure import Procedure
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.types import JsonObject

__all__ = ["VerifyTarget", "recorded_target", "trim_target", "verify_procedure"]


@dataclass(frozen=True)
class VerifyTarget:
    """The trim ``estimate`` with ``loads`` installed since (per slot, what changed:
    :attr:`trimd.app.apply.Applied.loads` or a proposal's slots)."""

    estimate: StaticEstimate
    loads: tuple[SlotLoad, ...]

    def to_dict(self) -> JsonObject:
        """The target's JSON document (module docstring)."""
        return {"estimate": estimate_to_dict(self.estimate),
                "proposal": {"slots": [slot_to_dict(ld) for ld in self.loads]}}

    @classmethod
    def from_dict(cls, d: object, source: str, profile: Profile) -> VerifyTarget:
        """The target of a JSON document :meth:`to_dict` wrote (or a trim's result: its
        proposal's slots); DataError naming ``source`` when it is malformed or its slots
        are not ``profile``'s."""
        if not isinstance(d, dict) or not isinstance(d.get("estimate"), dict):
            raise DataError(f"{source}: not a verify target (no estimate in it)")
        return cls(estimate_from_dict(d["estimate"], source),
                   tuple(installed_from_json(json.dumps(d), source, profile)))


def _pieces(items: object) -> list[InstalledPiece] | None:
    """A proposal's ``installed_before``/``installed_after`` list as pieces (None when
    absent or malformed: an older record)."""
    if not isinstance(items, list):
        return None
    try:
        return [InstalledPiece(str(x["slot"]), str(x["piece"]), int(x["count"]))
                for x in items]
    except (KeyError, TypeError, ValueError):
        return None


def _counts(pieces: Sequence[InstalledPiece]) -> dict[tuple[str, str], int]:
    return {(x.slot, x.piece): x.count for x in pieces if x.count > 0}


def recorded_target(estimate: dict[str, Any], proposal: dict[str, Any],
                    installed: Sequence[InstalledPiece] | None, profile: Profile,
                    source: str) -> VerifyTarget:
    """The verify target of a recorded trim or correction (its ``estimate`` and
    ``proposal`` JSON) with ``installed`` on the vehicle now (what ``trimd ballast apply``
    recorded since; None: nothing recorded, the proposal taken as fitted as proposed):
    the proposal's slots when ``installed`` is None or what it proposed; else what
    takes the configuration it started from (``installed_before``) to ``installed`` (the
    operator recorded other counts, ``--set``), so that the prediction, and the correction
    that builds on it, are for the ballast recorded as on the vehicle. DataError naming
    ``source`` for a malformed record, ProfileError for pieces ``profile`` lacks."""
    est = estimate_from_dict(estimate, source)
    before = _pieces(proposal.get("installed_before"))
    after = _pieces(proposal.get("installed_after"))
    if (installed is None or before is None or after is None
            or _counts(after) == _counts(installed)):
        return VerifyTarget.from_dict({"estimate": estimate, "proposal": proposal}, source,
                                      profile)
    return VerifyTarget(est, tuple(change_loads(profile, before, installed)))


def verify_procedure(profile: Profile, target: VerifyTarget, *, confirmed: bool,
                     source: str = "the verify target") -> Procedure[Never, Verification]:
    """The verify hold of ``target`` (:func:`trimd.ballast.verify.verify_hold`), built from
    the target's JSON document as it reads back (what a recording carries)."""
    read = VerifyTarget.from_dict(json.loads(json.dumps(target.to_dict())), source, profile)
    return Procedure(profile, confirmed=confirmed,
                     verify=lambda hold: verify_hold(hold, profile, read.estimate, read.loads))


def trim_target(path: str | None, profile: Profile, db: str | Path | None, vehicle: str
                ) -> VerifyTarget:
    """The verify target of the trim in ``path`` (a trim's result, or a verify hold's
    correction) or, with ``path`` None, of the vehicle's last trim in the history ``db``
    or of the correction since that was applied
    (:func:`trimd.app.history.chain.proposal_on_vehicle`), predicting for the ballast
    recorded as installed since the trim, if any (:func:`recorded_target`). DataError
    when there is none or it is malformed, UsageError for no ``path`` and no ``db``."""
    if path is not None:
        return VerifyTarget(read_estimate(path), tuple(read_installed(path, profile)))
    if db is None:
        raise UsageError("without the trim history, give the trim (TRIM.json)")
    with History(db) as history:
        found = proposal_on_vehicle(history, vehicle, profile.installed)
        recorded = installed_since_trim(history, vehicle)
        where = history.path
    if found is None:
        raise DataError(f"no trim with a proposal for vehicle {vehicle} in {where}: give "
                        "the trim (TRIM.json)")
    estimate, proposal, what = found
    return recorded_target(estimate, proposal, profile.installed if recorded else None,
                           profile, what)
