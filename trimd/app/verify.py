"""What a verify hold checks, as one JSON document, and the procedure that checks it.

The *verify target* is the trim being verified: its estimate (``estimate_to_dict``) and the
ballast installed since, per slot (``{"proposal": {"slots": [...]}}``, the shape of a
proposal's slots: what :func:`trimd.app.files.installed_from_json` reads). A live verify
hold is built from the document itself, not from the objects it was written from, and the
session recording carries the document (:class:`trimd.logs.recorder.TlogRecorder`), so a
replay of the recording builds the very same procedure and reproduces the verdict.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Never

from trimd.app.files import installed_from_json, read_estimate, read_installed
from trimd.app.history import History
from trimd.app.history.chain import installed_since_trim, proposal_on_vehicle
from trimd.ballast.changes import change_loads
from trimd.ballast.check import SlotLoad
from trimd.ballast.proposal import slot_to_dict
from trimd.ballast.verify import Verification, verify_hold
from trimd.core.errors import DataError
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import estimate_from_dict, estimate_to_dict
from trimd.core.procedure import Procedure
from trimd.core.profile import InstalledPiece, Profile

__all__ = ["read_target", "recorded_target", "trim_target", "verify_procedure",
           "verify_target"]


def verify_target(estimate: StaticEstimate, loads: Sequence[SlotLoad]) -> dict[str, Any]:
    """The verify target of the trim ``estimate`` with ``loads`` installed since (per slot,
    what changed: :attr:`trimd.app.apply.Applied.loads` or a proposal's slots)."""
    return {"estimate": estimate_to_dict(estimate),
            "proposal": {"slots": [slot_to_dict(ld) for ld in loads]}}


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
                    source: str) -> dict[str, Any]:
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
        loads = installed_from_json(json.dumps({"estimate": estimate, "proposal": proposal}),
                                    source, profile)
        return verify_target(est, loads)
    return verify_target(est, change_loads(profile, before, installed))


def read_target(target: object, source: str, profile: Profile
                ) -> tuple[StaticEstimate, list[SlotLoad]]:
    """The estimate and installed loads of a verify target (DataError naming ``source``
    when it is malformed or its slots are not ``profile``'s)."""
    if not isinstance(target, dict) or not isinstance(target.get("estimate"), dict):
        raise DataError(f"{source}: not a verify target (no estimate in it)")
    estimate = estimate_from_dict(target["estimate"], source)
    return estimate, installed_from_json(json.dumps(target), source, profile)


def verify_procedure(profile: Profile, target: dict[str, Any], *, confirmed: bool,
                     source: str = "the verify target") -> Procedure[Never, Verification]:
    """The verify hold of ``target`` (:func:`trimd.ballast.verify.verify_hold`), built from
    the target as its JSON reads back (what a recording carries)."""
    estimate, loads = read_target(json.loads(json.dumps(target)), source, profile)
    return Procedure(profile, confirmed=confirmed,
                     verify=lambda hold: verify_hold(hold, profile, estimate, loads))


def trim_target(path: str | None, profile: Profile, db: str | Path, vehicle: str
                ) -> dict[str, Any]:
    """The verify target of the trim in ``path`` (a trim's result, or a verify hold's
    correction) or, with ``path`` None, of the vehicle's last trim in the history ``db``
    or of the correction since that was applied
    (:func:`trimd.app.history.chain.proposal_on_vehicle`), predicting for the ballast
    recorded as installed since the trim, if any (:func:`recorded_target`). DataError
    when there is none or it is malformed."""
    if path is not None:
        return verify_target(read_estimate(path), read_installed(path, profile))
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
