"""The float check as a use case (``trimd float``): let go of the vehicle and measure the
attitude it floats at (:class:`trimd.core.float_check.FloatCheck`, docs/method.md §8), in a
:class:`~trimd.app.session.Session` that records it like every session.

The recording carries the float check's settings (:func:`float_settings`, a JSON block:
:data:`trimd.logs.recorder.FLOAT_BLOCK`), so that :func:`trimd.app.replay.replay_session_of`
replays it as a float check, built from the very settings, and reproduces the live result
exactly (:func:`float_from_settings`). The request is typed (:class:`FloatRequest`), not
the command line's arguments.
"""

from __future__ import annotations

import math
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Never

from trimd.app.headless import StdinConfirm, stop_on_signals
from trimd.app.history import History
from trimd.app.history.calibration import record_float_reference
from trimd.app.history.installed import current_installed
from trimd.app.history.trims import record_result, stored_text
from trimd.app.results import AnyPresenter
from trimd.app.session import Session, SessionResult
from trimd.app.verify import VerifyTarget
from trimd.ballast.correct import Correction, propose_float_correction
from trimd.core.errors import DataError
from trimd.core.float_check import FloatCheck
from trimd.core.floating import FloatResult, Verdict
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.profile_yaml import read_profile_text
from trimd.logs.recorder import TlogRecorder

__all__ = ["FloatRequest", "float_correction", "float_from_settings", "float_session",
           "float_settings", "run_float_check", "store_float_check"]


@dataclass(frozen=True)
class FloatRequest:
    """What a float check is asked to do.

    Attributes
    ----------
    profile_ref : the profile as the operator named it (a YAML path or a shipped name):
        its text goes into the recording.
    confirmed : the operator confirmed up front (``--yes``).
    depth_excursion_m : the largest depth change from the start [m]; None: the profile's
        ``max_depth_excursion_m``.
    record : where to record the session (a ``.tlog``); None: not recorded.
    for_correction : a correction follows unless it floats level (``--correct``): collect
        to the end (:class:`~trimd.core.float_check.FloatCheck`).
    """

    profile_ref: str
    confirmed: bool = False
    depth_excursion_m: float | None = None
    record: Path | None = None
    for_correction: bool = False


def float_settings(check: FloatCheck) -> dict[str, Any]:
    """What a float check's recording says of it: the settings its machine is built from."""
    return {"depth_excursion_m": check.depth_excursion_m,
            "for_correction": check.for_correction}


def float_from_settings(profile: Profile, settings: dict[str, Any], source: str, *,
                        confirmed: bool = False) -> FloatCheck:
    """The float check of recorded ``settings`` (:func:`float_settings`; without
    ``for_correction``, as recorded before it existed: False); DataError naming ``source``
    when they are malformed."""
    limit = settings.get("depth_excursion_m")
    correcting = settings.get("for_correction", False)
    if (not isinstance(limit, int | float) or not (math.isfinite(limit) and limit > 0)
            or not isinstance(correcting, bool)):
        raise DataError(f"{source}: the recorded float check is malformed ({settings!r})")
    return FloatCheck(profile, confirmed=confirmed, depth_excursion_m=float(limit),
                      for_correction=correcting)


def float_session(link: Link, profile: Profile, presenters: Sequence[AnyPresenter],
                  request: FloatRequest, *, wall_clock: bool = True
                  ) -> Session[Never, FloatResult]:
    """The float check's session on ``link``, recorded where ``request`` says."""
    check = FloatCheck(profile, confirmed=request.confirmed,
                       depth_excursion_m=request.depth_excursion_m,
                       for_correction=request.for_correction)
    recorder = None
    if request.record is not None:
        recorder = TlogRecorder(request.record, profile,
                                read_profile_text(request.profile_ref)[0],
                                float_check=float_settings(check))
    return Session(link, profile, recorder=recorder, presenters=presenters,
                   confirmed=request.confirmed, procedure=check, wall_clock=wall_clock)


async def run_float_check(open_link: Callable[[], Awaitable[Link]], profile: Profile,
                          request: FloatRequest, presenters: Sequence[AnyPresenter], *,
                          signals: bool = True) -> SessionResult[Never, FloatResult]:
    """``trimd float``: the float check on the link ``open_link`` opens, asking the
    operator at the terminal unless ``request.confirmed``; with ``signals``, SIGINT,
    SIGTERM and SIGHUP abort it (the vehicle is released, the log closed)."""
    link = await open_link()
    session = float_session(link, profile, presenters, request)
    if not request.confirmed:
        session.add_presenter(StdinConfirm(session))
    if signals:
        stop_on_signals(session.abort)
    return await session.run()


def float_correction(f: FloatResult, target: VerifyTarget, profile: Profile,
                     db: str | Path | None, vehicle: str) -> Correction | None:
    """After the float check ``f`` of the trim ``target`` (:func:`trimd.app.verify.
    trim_target`): the correction of the ballast installed now (the history ``db``'s for
    ``vehicle``, else the profile's) for the vehicle as it floated
    (:func:`trimd.ballast.correct.floated_vehicle`); None when it floats level. DataError
    for a target that does not fit the profile, ProfileError for installed pieces it does
    not have."""
    if f.verdict is Verdict.LEVEL:
        return None
    installed, _ = current_installed(db, vehicle, profile)
    return propose_float_correction(f, target.estimate, target.loads, profile, installed)


def store_float_check(db: str | Path, vehicle: str, profile: Profile,
                      result: SessionResult[Never, FloatResult],
                      correction: Correction | None) -> str | None:
    """Store the float check ``result`` (with its session log) under ``vehicle`` in the
    history ``db``, its ``correction`` linked to it (a later ``trimd run --verify`` or
    ``trimd float --correct`` of the vehicle checks that correction once it is applied:
    :mod:`trimd.app.history.chain`); a line for people, None when the session gave no
    result; with the outcome of the float reference it makes with the level hold just
    before it (:func:`trimd.app.history.calibration.record_float_reference`). DataError
    when the file cannot take it, ProfileError when its installed ballast is not the
    profile's."""
    installed, _ = current_installed(db, vehicle, profile)
    with History(db) as history:
        stored = record_result(history, vehicle, profile.name, result, correction=correction)
        f = result.verification
        outcome = None if stored is None or f is None else record_float_reference(
            history, vehicle, profile, f, stored, installed)
    if stored is None:
        return None
    text = stored_text(vehicle, history.path)
    return text if outcome is None else f"{text}; {outcome.message}"
