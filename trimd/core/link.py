"""The one Link interface: what the session, replay and tests need of a vehicle connection.

A :class:`Link` yields typed samples (:mod:`trimd.core.samples`) in SI units, body FRD and
NED, and accepts typed commands. Drivers (``trimd.drivers``) and the log replay
(``trimd.logs.replay``) implement it; :func:`trimd.app.connect.open_link` opens one by URL.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from typing import Protocol, runtime_checkable

from trimd.core.announce import Announcement
from trimd.core.samples import Command, Sample

__all__ = ["Announces", "Link", "RawPackets", "Truthful"]


@runtime_checkable
class Link(Protocol):
    """What the daemon, replay and tests need of a vehicle connection."""

    description: str

    def samples(self) -> AsyncIterator[Sample]:
        """Samples as they arrive, until the link is closed."""
        ...

    async def send(self, command: Command) -> None:
        """Send a command; raise LinkError('not supported …') for a missing capability."""
        ...

    async def close(self) -> None:
        """Release control and close the transport (idempotent)."""
        ...


@runtime_checkable
class RawPackets(Protocol):
    """A link that hands over every packet exactly as received (MAVLink), so a recorder
    can keep the packets rather than re-encoded samples."""

    on_raw: Callable[[float, bytes], None] | None


@runtime_checkable
class Announces(Protocol):
    """A link that can put trimd's texts and values where the pilot's ground station
    shows them (:mod:`trimd.core.announce`; MAVLink: STATUSTEXT and NAMED_VALUE_FLOAT).
    ``announce`` never blocks and never fails: what the link cannot send within its
    budget it drops, and after ``close`` it ignores the call."""

    def announce(self, item: Announcement) -> None:
        """Queue ``item`` for sending."""
        ...


@runtime_checkable
class Truthful(Protocol):
    """A link that knows the truth it simulates (the simulated vehicle), for the demo."""

    def truth(self) -> object:
        """What the vehicle really carries, printable."""
        ...
