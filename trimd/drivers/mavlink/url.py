"""The ``mavlink:`` link URL: a pymavlink connection string plus trimd's options.

Syntax (``docs/mavlink.md``)::

    mavlink:<connection>[?key=value&key=value…]

    connection   udpin:HOST:PORT     listen for the vehicle (the usual topside end;
                                     ``udp:`` means the same)
                 udpout:HOST:PORT    send to the vehicle first (e.g. BlueOS at 192.168.2.2)
                 tcp:HOST:PORT       connect to a TCP server (SITL, mavlink-router)
                 /dev/ttyACM0[,BAUD] a serial device (default 115200 baud)

    sysid=N      the vehicle's system id (default: the first autopilot that is not a GCS)
    timeout=S    heartbeat timeout [s] before the link is reported lost
                 (default: 3, or the profile's procedure.link_timeout_s if longer)
    gcs=N        trimd's own system id (default 255: ArduSub's SYSID_MYGCS)
    key=PATH     MAVLink 2 signing key: a file of 32 raw bytes or 64 hex digits; with a key,
                 every unsigned or badly signed packet received is refused
    pilot=hold   neutral MANUAL_CONTROL only while trimd commands (default; the operator's
                 ground station supplies pilot input otherwise)
    pilot=always neutral MANUAL_CONTROL from the first heartbeat on: trimd is the only
                 ground station and must keep ArduSub's pilot-input failsafe quiet
                 (either way: never while another ground station's heartbeat is seen)
    depth=SOURCE vfr_hud (default), global_position or pressure (SCALED_PRESSURE2, Bar30)
    rate=HZ      the rate [Hz, 1..50] trimd asks for ATTITUDE, SERVO_OUTPUT_RAW and the depth
                 message (default 10, 10 and 5; ``trimd excite`` asks for 50 unless given)
    ids=gcs      trimd sends as a ground station: system ``gcs=``, component 190 (default)
    ids=vehicle  trimd sends as a component of the vehicle (beside the autopilot, so that
                 ground stations show its STATUSTEXT): system ``sysid=`` (default 1, ArduSub's
                 SYSID_THISMAV), component ``comp=``; then it sends no MANUAL_CONTROL
                 (ArduSub takes pilot input only from its ground station) and
                 ``pilot=always`` is refused
    comp=N       trimd's component id (default 190 with ids=gcs, 191 with ids=vehicle:
                 MAV_COMP_ID_ONBOARD_COMPUTER)
    announce=off no STATUSTEXT or NAMED_VALUE_FLOAT from trimd (default on)

Everything else is refused with a :class:`~trimd.core.errors.LinkError` that says what would
work: pymavlink itself opens a serial port for any string it does not recognise.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, cast

from trimd.core.errors import LinkError
from trimd.drivers.mavlink.decode import DepthSource

__all__ = ["GCS_COMPONENT", "ONBOARD_COMPONENT", "Ids", "MavlinkOptions", "PilotPolicy",
           "load_signing_key", "parse_mavlink_url"]

PilotPolicy = Literal["hold", "always"]
Ids = Literal["gcs", "vehicle"]

GCS_COMPONENT = 190         # MAV_COMP_ID_MISSIONPLANNER: a ground station
ONBOARD_COMPONENT = 191     # MAV_COMP_ID_ONBOARD_COMPUTER: a companion computer
_VEHICLE_SYSID = 1          # ArduSub's default SYSID_THISMAV

_NET = re.compile(r"^(udpin|udpout|udp|tcp):([^:?&]+):(\d+)$")
_SERIAL = re.compile(r"^(/dev/[^,]+|/[^,]*tty[^,]*|COM\d+)(?:,(\d+))?$")
_FORMS = ("udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT or a serial device "
          "/dev/ttyXXX[,BAUD]")
_KEYS = ("sysid", "timeout", "gcs", "key", "pilot", "depth", "rate", "ids", "comp",
         "announce")
_DEPTH: tuple[DepthSource, ...] = ("vfr_hud", "global_position", "pressure")
_PILOT: tuple[PilotPolicy, ...] = ("hold", "always")
_IDS: tuple[Ids, ...] = ("gcs", "vehicle")
_ON_OFF = ("on", "off")


@dataclass(frozen=True, slots=True)
class MavlinkOptions:
    """A parsed ``mavlink:`` URL (see the module docstring)."""

    device: str           # the pymavlink connection string (``udpin:0.0.0.0:14550``)
    baud: int = 115200    # serial devices only
    sysid: int | None = None
    timeout_s: float = 3.0
    gcs_sysid: int = 255
    key_path: str | None = None
    pilot: PilotPolicy = "hold"
    depth: DepthSource = "vfr_hud"
    stream_hz: float | None = None   # rate= (None: trimd.drivers.mavlink.commands.STREAMS)
    ids: Ids = "gcs"
    compid: int = GCS_COMPONENT
    announce: bool = True

    @property
    def serial(self) -> bool:
        return not _NET.match(self.device)

    @property
    def source(self) -> tuple[int, int]:
        """(system, component) trimd sends from: its own, or the vehicle's system."""
        if self.ids == "vehicle":
            return (self.sysid or _VEHICLE_SYSID, self.compid)
        return (self.gcs_sysid, self.compid)


def _int(key: str, text: str, lo: int, hi: int) -> int:
    if not text.isdigit() or not lo <= int(text) <= hi:
        raise LinkError(f"mavlink option {key}={text!r}: expected an integer {lo}..{hi}")
    return int(text)


def _connection(text: str) -> tuple[str, int]:
    net = _NET.match(text)
    if net:
        kind, host, port = net.groups()
        _int("port", port, 0 if kind in ("udpin", "udp") else 1, 65535)
        return (f"udpin:{host}:{port}" if kind == "udp" else text), 115200
    serial = _SERIAL.match(text)
    if serial:
        device, baud = serial.groups()
        return device, 115200 if baud is None else _int("baud", baud, 50, 10_000_000)
    if text.lower().endswith((".tlog", ".bin")):
        raise LinkError(f"'{text}' is a log file: open it with replay:{text}")
    if text.startswith(("tcpin:", "udpbcast:", "mcast:", "ws:", "wss:", "wsserver:")):
        raise LinkError(f"mavlink connection '{text}' is not supported by trimd: use {_FORMS}")
    raise LinkError(f"unknown mavlink connection '{text}': use {_FORMS}, "
                    "e.g. mavlink:udpin:0.0.0.0:14550")


def _number(values: dict[str, str], key: str, lo: float, hi: float, unit: str
            ) -> float | None:
    """The number ``values[key]`` in [lo, hi], None when absent; LinkError otherwise."""
    if key not in values:
        return None
    try:
        number = float(values[key])
    except ValueError:
        number = math.nan
    if not lo <= number <= hi:
        raise LinkError(f"mavlink option {key}={values[key]!r}: expected {unit} between "
                        f"{lo:g} and {hi:g}")
    return number


def parse_mavlink_url(rest: str, *, default_timeout_s: float,
                      default_stream_hz: float | None = None) -> MavlinkOptions:
    """Parse what follows ``mavlink:``; LinkError naming the problem for anything unknown.
    ``default_stream_hz`` is the ``rate`` when the URL does not give one.

    Examples
    --------
    >>> o = parse_mavlink_url("udpin:0.0.0.0:14550?sysid=1&timeout=2", default_timeout_s=3)
    >>> o.device, o.sysid, o.timeout_s
    ('udpin:0.0.0.0:14550', 1, 2.0)
    >>> parse_mavlink_url("/dev/ttyACM0,57600", default_timeout_s=3).baud
    57600
    >>> parse_mavlink_url("udpout:127.0.0.1:14551?ids=vehicle", default_timeout_s=3).source
    (1, 191)
    """
    connection, _, query = rest.partition("?")
    if not connection:
        raise LinkError(f"mavlink: needs a connection: {_FORMS}")
    device, baud = _connection(connection)
    values: dict[str, str] = {}
    for item in filter(None, query.split("&")):
        key, eq, value = item.partition("=")
        if key not in _KEYS:
            raise LinkError(f"unknown mavlink option '{key}' (known: {', '.join(_KEYS)})")
        if not eq or not value:
            raise LinkError(f"mavlink option '{key}' needs a value: {key}=…")
        values[key] = value
    timeout_s = _number(values, "timeout", 0.1, 600.0, "seconds")
    stream_hz = _number(values, "rate", 1.0, 50.0, "Hz")
    for key, allowed in (("pilot", _PILOT), ("depth", _DEPTH), ("ids", _IDS),
                         ("announce", _ON_OFF)):
        if key in values and values[key] not in allowed:
            raise LinkError(f"mavlink option {key}={values[key]!r}: expected one of "
                            f"{', '.join(allowed)}")
    ids = cast(Ids, values.get("ids", "gcs"))
    if ids == "vehicle" and values.get("pilot") == "always":
        raise LinkError("mavlink options ids=vehicle and pilot=always: ArduSub takes pilot "
                        "input only from its ground station (SYSID_MYGCS); drop one")
    sysid = _int("sysid", values["sysid"], 1, 255) if "sysid" in values else None
    return MavlinkOptions(
        device=device, baud=baud,
        sysid=_VEHICLE_SYSID if ids == "vehicle" and sysid is None else sysid,
        timeout_s=default_timeout_s if timeout_s is None else timeout_s,
        gcs_sysid=_int("gcs", values["gcs"], 1, 255) if "gcs" in values else 255,
        key_path=values.get("key"),
        pilot=cast(PilotPolicy, values.get("pilot", "hold")),
        depth=cast(DepthSource, values.get("depth", "vfr_hud")),
        stream_hz=default_stream_hz if stream_hz is None else stream_hz,
        ids=ids, compid=_int("comp", values["comp"], 1, 255) if "comp" in values else (
            ONBOARD_COMPONENT if ids == "vehicle" else GCS_COMPONENT),
        announce=values.get("announce", "on") == "on")


def load_signing_key(path: str) -> bytes:
    """The 32-byte MAVLink 2 signing secret in ``path`` (32 raw bytes or 64 hex digits)."""
    try:
        data = Path(path).expanduser().read_bytes()
    except OSError as exc:
        raise LinkError(f"signing key {path}: cannot read: {exc.strerror or exc}") from None
    if len(data) == 32:
        return data
    text = data.strip()
    if len(text) == 64 and re.fullmatch(rb"[0-9a-fA-F]{64}", text):
        return bytes.fromhex(text.decode())
    raise LinkError(f"signing key {path}: expected 32 raw bytes or 64 hex digits, found "
                    f"{len(data)} bytes")
