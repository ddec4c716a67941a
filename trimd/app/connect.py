"""Opening a vehicle link from a URL (``sim``, ``mavlink:…``, ``serial:…``, ``replay:…``).

:func:`open_link` picks the driver from a URL and refuses anything
it does not know (pymavlink would silently open a serial port for a typo).
"""

from __future__ import annotations

import difflib

from trimd.core.errors import LinkError
from trimd.core.link import Link
from trimd.core.profile import Profile

__all__ = ["SCHEMES", "open_link", "parse_link_url"]

SCHEMES = ("sim", "mavlink", "serial", "replay")


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


async def open_link(url: str, profile: Profile, *, stream_hz: float | None = None) -> Link:
    """Open the link named by ``url`` for a vehicle described by ``profile``;
    ``stream_hz``: the telemetry rate (attitude, thruster outputs, depth) to ask the vehicle
    for where the URL does not say (MAVLink and the simulator; None: the driver's own)."""
    scheme, rest = parse_link_url(url)
    if scheme == "sim":
        from trimd.drivers.sim.link import open_sim_link

        return open_sim_link(rest, profile, stream_hz)
    if scheme == "serial":
        from trimd.drivers.serial.link import open_serial_link

        return open_serial_link(rest, profile)
    if scheme == "mavlink":
        from trimd.drivers.mavlink.link import open_mavlink_link

        return open_mavlink_link(rest, profile, stream_hz)
    if scheme == "replay":
        from trimd.logs.replay import ReplayLink

        if not rest:
            raise LinkError("replay: needs a path, e.g. replay:session.tlog")
        return ReplayLink(rest, profile)
    raise LinkError(f"link scheme '{scheme}' ({rest or 'no options'}) is not available yet")
