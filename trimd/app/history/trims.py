"""What ``trimd run`` stores in the history when a session ends with an estimate, or a
verify hold with its verdict (and its correction, linked to it)."""

from __future__ import annotations

import time

from trimd.app.history.store import History
from trimd.app.results import AnyResult
from trimd.ballast.correct import Correction
from trimd.ballast.proposal import proposal_to_dict
from trimd.ballast.verify import Verification, verification_to_dict
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.floating import FloatResult, float_to_dict

__all__ = ["record_result", "stored_text"]


def stored_text(vehicle: str, path: object) -> str:
    """The line for people that a session's result was stored under ``vehicle`` in the
    history at ``path``."""
    return f"trim history: stored for vehicle {vehicle} in {path}"


def record_result(history: History, vehicle: str, profile: str, result: AnyResult,
                  t_unix: float | None = None, correction: Correction | None = None
                  ) -> int | None:
    """Store ``result``'s estimate, proposal and session log path under ``vehicle`` (or a
    verify hold's verification, or a float check's result, with its ``correction``); the
    record's id, or None (nothing stored) when the session produced none of them."""
    t = time.time() if t_unix is None else t_unix
    linked = None if correction is None else (estimate_to_dict(correction.vehicle),
                                              proposal_to_dict(correction.proposal))
    if isinstance(result.verification, Verification):
        return history.record_verify(vehicle, t, {**verification_to_dict(result.verification),
                                                  "log_path": result.log_path}, linked)
    if isinstance(result.verification, FloatResult):
        return history.record_float(vehicle, t, {**float_to_dict(result.verification),
                                                 "log_path": result.log_path}, linked)
    if result.estimate is None:
        return None
    proposal = None if result.proposal is None else proposal_to_dict(result.proposal)
    return history.record_trim(vehicle, profile, t,
                               estimate_to_dict(result.estimate), proposal, result.log_path)
