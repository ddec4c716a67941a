"""Vehicle links: one small async interface over MAVLink, serial, the simulator and replays.

A :class:`Link` yields typed samples (``drivers.samples``) in SI units and FRD/NED, and
accepts typed commands. :func:`open_link` picks the driver from a URL and refuses anything
it does not know (pymavlink would silently open a serial port for a typo).
"""

from __future__ import annotations

import difflib
from collections.abc import AsyncIterator
from typing import Protocol, runtime_checkable

from trimd.errors import LinkError
from trimd.profile import Profile
from trimd.samples import (
    Arm,
    Attitude,
    Battery,
    Command,
    Depth,
    Health,
    HoldAttitude,
    OpenLoop,
    Release,
    Sample,
    Thrusters,
    Velocity,
)

__all__ = [
    "Arm", "Attitude", "Battery", "Command", "Depth", "Health", "HoldAttitude", "Link",
    "OpenLoop", "Release", "Sample", "Thrusters", "Velocity", "open_link", "parse_link_url",
]

SCHEMES = ("sim", "mavlink", "serial", "replay")


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


def parse_link_url(url: str) -> tuple[str, str]:
    """Split ``scheme:rest``; LinkError naming the nearest scheme for anything unknown.

    Examples
    --------
    >>> parse_link_url("mavlink:udpin:0.0.0.0:14550")
    ('mavlink', 'udpin:0.0.0.0:14550')
    >>> parse_link_url("sim")
    ('sim', '')
    """
    scheme, _, rest = url.partition(":")
    if scheme in SCHEMES:
        return scheme, rest
    if scheme in ("udp", "udpin", "udpout", "tcp", "tcpin"):
        hint = f"did you mean 'mavlink:{url}'?"
    else:
        near = difflib.get_close_matches(scheme, SCHEMES, n=1)
        hint = f"did you mean '{near[0]}:…'?" if near else f"use one of {', '.join(SCHEMES)}"
    raise LinkError(f"unknown link '{url}': {hint}")


async def open_link(url: str, profile: Profile) -> Link:
    """Open the link named by ``url`` for a vehicle described by ``profile``."""
    scheme, rest = parse_link_url(url)
    if scheme == "sim":
        from drivers.sim.link import open_sim_link

        return open_sim_link(rest, profile)
    if scheme == "serial":
        from drivers.serial_link import open_serial_link

        return open_serial_link(rest, profile)
    if scheme == "mavlink":
        from drivers.mavlink import open_mavlink_link

        return open_mavlink_link(rest, profile)
    if scheme == "replay":
        from replay.link import ReplayLink

        if not rest:
            raise LinkError("replay: needs a path, e.g. replay:session.tlog")
        return ReplayLink(rest, profile)
    raise LinkError(f"link scheme '{scheme}' ({rest or 'no options'}) is not available yet")
