"""The replay of a trimd recording as a use case: which profile it runs with, and the
session that feeds the recorded samples through the same procedure as the live run (a trim,
or a verify hold when the recording carries its target), so that it reproduces the live
estimate, proposal or verdict exactly.
"""

from __future__ import annotations

import sys

import yaml

from trimd.app.session import Presenter, Session, SessionResult
from trimd.app.verify import verify_procedure
from trimd.ballast.proposal import Proposal
from trimd.ballast.propose import propose_ballast
from trimd.core.errors import DataError
from trimd.core.estimate import StaticEstimate
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile, parse_profile
from trimd.logs.replay import (
    ReplayLink,
    recorded_profile_yaml,
    recorded_verify_target,
    with_recorded_thrust_map,
)

__all__ = ["replay_profile", "replay_session", "replay_session_of"]


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
                      presenters: list[Presenter], method: str) -> Session:
    """The replay's session over ``link`` (the recording ``path``): a verify hold when
    the recording carries a verify target, else the trim, proposing by ``method``;
    confirmed where the live session was (the recording's :class:`Confirmed`)."""
    target = recorded_verify_target(path)
    procedure = None if target is None else verify_procedure(
        profile, target, confirmed=False, source=f"{path} (recorded verify target)")

    def propose(estimate: StaticEstimate) -> Proposal:
        return propose_ballast(estimate, profile, method=method)

    return Session(link, profile, recorder=None, presenters=presenters, confirmed=False,
                   propose=propose, procedure=procedure, wall_clock=False)


async def replay_session(path: str, profile: Profile, *, speed: float | None,
                         presenters: list[Presenter], method: str
                         ) -> tuple[SessionResult, ReplayLink]:
    """Run the recorded procedure (trim or verify hold) over a recording; return its result
    and the link."""
    link = ReplayLink(path, profile, speed=speed)
    session = replay_session_of(link, path, profile, presenters=presenters, method=method)
    return await session.run(), link
