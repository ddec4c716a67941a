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
from typing import Any

from trimd.app.files import installed_from_json
from trimd.ballast.check import SlotLoad
from trimd.ballast.proposal import slot_to_dict
from trimd.ballast.verify import verify_hold
from trimd.core.errors import DataError
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import estimate_from_dict, estimate_to_dict
from trimd.core.procedure import Procedure
from trimd.core.profile import Profile

__all__ = ["read_target", "verify_procedure", "verify_target"]


def verify_target(estimate: StaticEstimate, loads: Sequence[SlotLoad]) -> dict[str, Any]:
    """The verify target of the trim ``estimate`` with ``loads`` installed since (per slot,
    what changed: :attr:`trimd.app.apply.Applied.loads` or a proposal's slots)."""
    return {"estimate": estimate_to_dict(estimate),
            "proposal": {"slots": [slot_to_dict(ld) for ld in loads]}}


def read_target(target: object, source: str, profile: Profile
                ) -> tuple[StaticEstimate, list[SlotLoad]]:
    """The estimate and installed loads of a verify target (DataError naming ``source``
    when it is malformed or its slots are not ``profile``'s)."""
    if not isinstance(target, dict) or not isinstance(target.get("estimate"), dict):
        raise DataError(f"{source}: not a verify target (no estimate in it)")
    estimate = estimate_from_dict(target["estimate"], source)
    return estimate, installed_from_json(json.dumps(target), source, profile)


def verify_procedure(profile: Profile, target: dict[str, Any], *, confirmed: bool,
                     source: str = "the verify target") -> Procedure:
    """The verify hold of ``target`` (:func:`trimd.ballast.verify.verify_hold`), built from
    the target as its JSON reads back (what a recording carries)."""
    estimate, loads = read_target(json.loads(json.dumps(target)), source, profile)
    return Procedure(profile, confirmed=confirmed,
                     verify=lambda hold: verify_hold(hold, profile, estimate, loads))
