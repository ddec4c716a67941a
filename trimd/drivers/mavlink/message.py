"""The pymavlink edge: what trimd uses of pymavlink's untyped objects, as Protocols.

pymavlink has no type information. Its messages carry their fields as attributes named by
the MAVLink XML (``msg.roll`` [rad], ``msg.servo1_raw`` [µs] …), and its encoder has one
``<message>_encode`` and ``<message>_send`` method per message. These Protocols name the
few methods trimd calls on every message or connection and leave the generated ones to
``__getattr__``: the one place where trimd's types stop. :func:`speak_mavlink2` pins a
new connection to MAVLink 2 and the ardupilotmega dialect.
"""

from __future__ import annotations

from typing import Any, Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

__all__ = ["MavConnection", "MavEncoder", "MavLogReader", "MavMessage", "speak_mavlink2"]


class MavMessage(Protocol):
    """A decoded MAVLink (or DataFlash) message; its fields by their XML names."""

    def get_type(self) -> str: ...

    def __getattr__(self, name: str) -> Any: ...


class MavEncoder(Protocol):
    """pymavlink's ``MAVLink`` object: ``<message>_encode`` / ``<message>_send`` per
    message of the dialect, ``decode`` of a packet's bytes, its state (``seq``) set by
    name."""

    def __getattr__(self, name: str) -> Any: ...

    def __setattr__(self, name: str, value: Any) -> None: ...


class MavConnection(Protocol):
    """A pymavlink connection (``mavutil.mavlink_connection``) with its encoder ``mav``;
    its settings (``first_byte``, ``handle_eof`` …) set by name."""

    mav: MavEncoder

    def recv_msg(self) -> MavMessage | None: ...

    def close(self) -> None: ...

    def __getattr__(self, name: str) -> Any: ...

    def __setattr__(self, name: str, value: Any) -> None: ...


class MavLogReader(Protocol):
    """pymavlink's DataFlash reader (``DFReader.DFReader_binary``): records one at a time,
    and where in the file [byte] it is."""

    offset: int
    data_len: int

    def recv_msg(self) -> MavMessage | None: ...


def speak_mavlink2(conn: MavConnection, sysid: int, compid: int) -> MavConnection:
    """``conn`` (a new ``mavutil.mavlink_connection``) speaking MAVLink 2 with the
    ardupilotmega dialect from the first byte, as ``sysid``/``compid`` (pinned here, not
    through the MAVLINK20 environment variable)."""
    conn.mav = mavlink2.MAVLink(conn, srcSystem=sysid, srcComponent=compid)
    conn.mav.robust_parsing = True
    conn.WIRE_PROTOCOL_VERSION = "2.0"
    conn.first_byte = False
    return conn
