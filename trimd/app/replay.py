"""The replay of a trimd recording as a use case: which profile it runs with, and the
session that feeds the recorded samples through the same procedure as the live run (a trim,
a verify hold when the recording carries its target, a calibration's level hold, a float
check), so that it reproduces the live estimate, proposal, verdict or float attitude
exactly.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import replace

import yaml

from trimd.app.calibrate import (
    hold_from_record,
    level_hold_procedure,
    recorded_hold_s,
    recorded_sides,
)
from trimd.app.calibration_loads import (
    CalibrationRun,
    Load,
    calibration_experiment,
    check_against_profile,
)
from trimd.app.float_check import float_from_settings
from trimd.app.results import AnyPresenter, AnyResult, Finding
from trimd.app.session import Machine, Session
from trimd.app.verify import VerifyTarget, verify_procedure
from trimd.ballast.proposal import Proposal
from trimd.ballast.propose import propose_ballast
from trimd.core.errors import DataError, EstimationError
from trimd.core.estimate import HoldSamples, StaticEstimate
from trimd.core.events import Phase
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile, parse_profile
from trimd.logs.replay import (
    ReplayLink,
    recorded_calibration_hold,
    recorded_float_check,
    recorded_profile_yaml,
    recorded_verify_target,
    with_recorded_thrust_map,
)

__all__ = ["replay_calibration", "replay_profile", "replay_session", "replay_session_of"]


def replay_profile(path: str, name: str | None) -> tuple[Profile, bool]:
    """The profile to use and whether the log is a trimd recording; a recording's thrust
    map calibration with it (what the live session used, docs/method.md §7)."""
    profile, recording = _profile(path, name)
    return (with_recorded_thrust_map(path, profile) if recording else profile), recording


def _profile(path: str, name: str | None) -> tuple[Profile, bool]:
    """The profile (recorded, or ``name``) and whether the log is a trimd recording."""
    try:
        text = recorded_profile_yaml(path)
    except DataError as exc:  # a trimd recording whose profile block is damaged
        if not name:
            raise DataError(f"{exc}: pass --profile to replay it with that profile") from None
        print(f"trimd: warning: {exc}; replaying with --profile {name}", file=sys.stderr)
        return load_profile(name), True
    if name:
        return load_profile(name), text is not None
    if text is None:
        raise DataError(f"{path}: not a trimd recording, so it carries no profile: "
                        "pass --profile")
    return parse_profile(yaml.safe_load(text), f"{path} (recorded profile)"), True


def replay_session_of(link: Link, path: str, profile: Profile, *,
                      presenters: Sequence[AnyPresenter], method: str
                      ) -> Session[Proposal, Finding]:
    """The replay's session over ``link`` (the recording ``path``): a verify hold when
    the recording carries a verify target, a calibration's level hold when it says it is
    one, a float check when it carries one's settings, else the trim, proposing by
    ``method``; confirmed where the live session was (the recording's
    :class:`Confirmed`)."""
    recorded = recorded_verify_target(path)
    procedure: Machine[Proposal, Finding] | None = None
    if recorded is not None:
        source = f"{path} (recorded verify target)"
        procedure = verify_procedure(profile, VerifyTarget.from_dict(recorded, source, profile),
                                     confirmed=False, source=source)
    hold = recorded_calibration_hold(path)
    if hold is not None:
        procedure = level_hold_procedure(profile, confirmed=False,
                                         hold_s=recorded_hold_s(hold, path))
    settings = recorded_float_check(path)
    if settings is not None:
        procedure = float_from_settings(profile, settings, f"{path} (recorded float check)")

    def propose(estimate: StaticEstimate) -> Proposal:
        return propose_ballast(estimate, profile, method=method)

    return Session(link, profile, recorder=None, presenters=presenters, confirmed=False,
                   propose=propose, procedure=procedure, wall_clock=False)


async def replay_session(path: str, profile: Profile, *, speed: float | None,
                         presenters: Sequence[AnyPresenter], method: str
                         ) -> tuple[AnyResult, ReplayLink]:
    """Run the recorded procedure (trim or verify hold) over a recording; return its result
    and the link."""
    link = ReplayLink(path, profile, speed=speed)
    session = replay_session_of(link, path, profile, presenters=presenters, method=method)
    return await session.run(), link


async def replay_calibration(paths: Sequence[str], name: str | None) -> CalibrationRun:
    """A deliberate calibration reproduced from the recordings of its level holds, in
    order (:mod:`trimd.app.calibrate`): each hold replayed, the experiments of each two
    consecutive holds with the recorded weights, checked in order against the thrust map
    the live session had (recorded with it), as the live ones were, each band load's side
    as recorded; stored nowhere.
    DataError when the recordings are not the holds of one series in order (a series cut
    short replays as far as its recordings go); EstimationError when a hold does not
    replay to a steady one."""
    if len(paths) < 2:
        raise DataError("a calibration replays from two or more recordings of its level "
                        "holds, in order")
    holds: list[HoldSamples] = []
    profiles = []
    series: tuple[Load, ...] = ()
    for k, path in enumerate(paths):
        d = recorded_calibration_hold(path)
        if d is None:
            raise DataError(f"{path}: not a recording of a calibration's level hold (trimd "
                            "calibrate records one per hold)")
        index, weights = hold_from_record(d, path)
        if k and series and weights[:len(series)] != series:  # a band series grows
            raise DataError(f"{paths[0]} and {path} record different weights: not holds of "
                            "one calibration")
        if index != k:
            raise DataError(f"{path}: hold {index + 1} of its calibration, given as hold "
                            f"{k + 1}: give the recordings in the order of their holds, the "
                            "one before any weight first")
        series, last = weights, d
        profiles.append(replay_profile(path, name)[0])
        result, _ = await replay_session(path, profiles[-1], speed=None, presenters=[],
                                         method="milp")
        if result.phase is not Phase.DONE or not isinstance(result.verification, HoldSamples):
            raise EstimationError(f"{path}: level hold {k + 1} did not replay to a steady "
                                  f"hold: {result.reason}")
        holds.append(result.verification)
    experiments = [calibration_experiment(holds[k], holds[k + 1], profiles[0], series[k],
                                          series[k - 1] if k else None)
                   for k in range(len(holds) - 1)]
    stopped = ("" if len(holds) == len(series) + 1 else
               f"replayed {len(holds) - 1} of the series' {len(series)} weights")
    sides = recorded_sides(last, len(experiments), paths[-1])
    return replace(check_against_profile(experiments, profiles[0], stopped), sides=sides)
