"""The terminal UI over a replay of a trimd recording, with pause and speed keys."""

from __future__ import annotations

from trimd.app.replay import replay_session_of
from trimd.core.profile import Profile
from trimd.logs.replay import ReplayLink
from trimd.tui import TrimApp, make_app
from trimd.tui.replay_pace import PacedReplay

__all__ = ["replay_app"]


def replay_app(path: str, profile: Profile, *, speed: float, method: str) -> TrimApp:
    """The TUI over a replay of ``path`` starting at ``speed`` × real time (inf: as fast
    as possible); its heartbeat age is on the recording's clock."""
    link = PacedReplay(ReplayLink(path, profile), speed=speed)
    session = replay_session_of(link, path, profile, presenters=[], method=method)
    return make_app(session, profile, link_description=link.description, replay=link,
                    clock=lambda: link.t_s)
