"""The trimd serial line protocol (``docs/serial-protocol.md``): pure encode and decode.

NMEA-0183-style ASCII sentences ``$TTSSS,f1,f2,…*hh\\r\\n``: talker ``VH`` (the vehicle)
or ``TR`` (trimd), a three-letter sentence id, comma-separated fields and the XOR of every
byte between ``$`` and ``*`` as two hex digits. On the wire: degrees, degrees per second,
metres, volts, microseconds and milliseconds; the conversions to and from the SI/FRD/NED
values of :mod:`trimd.core.samples` live here, one function a direction, every one tested.

No I/O and no clock: :class:`LineParser` turns bytes into :class:`Sentence` values and
counts every line it drops (never raises); :func:`to_sample` / :func:`to_command` turn a
sentence into a sample or command; :func:`encode_sample` / :func:`encode_command` go
back to bytes.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import reduce
from operator import xor

from trimd.core.samples import (
    Arm,
    Attitude,
    Battery,
    Command,
    Confirmed,
    Depth,
    Health,
    HoldAttitude,
    OpenLoop,
    PilotInput,
    Release,
    Sample,
    Thrusters,
    VehicleText,
    Velocity,
)
from trimd.drivers.serial.modes import mode_class

__all__ = [
    "BAD_COUNTERS",
    "CONTROLS",
    "MAX_LINE_BYTES",
    "MAX_OUTPUTS",
    "TRIMD",
    "VEHICLE",
    "VERSION",
    "Heartbeat",
    "LineParser",
    "Sentence",
    "Version",
    "checksum",
    "encode",
    "encode_command",
    "encode_sample",
    "heading_deg",
    "to_command",
    "to_sample",
]

VERSION = 1
#: Longest line, from ``$`` to the closing LF inclusive [bytes].
MAX_LINE_BYTES = 128
MAX_OUTPUTS = 16
VEHICLE, TRIMD = "VH", "TR"
#: Who is in control, as the vehicle's STA sentence reports it.
CONTROLS = ("PILOT", "HOLD", "OPEN")
#: The counters of dropped lines, in the order a receiver checks them.
BAD_COUNTERS = ("too_long", "malformed", "bad_checksum", "unknown", "bad_fields", "bad_value")

#: A number: ``[+-]digits[.digits]`` or ``.digits`` (ASCII digits; no ``9.``, ``-.5``,
#: exponent, ``nan``, ``inf``, space or ``_``).
_NUMBER = re.compile(r"[+-]?[0-9]+(?:\.[0-9]+)?|\.[0-9]+")
#: An integer: an unsigned string of 1 to 10 ASCII digits.
_INTEGER = re.compile(r"[0-9]{1,10}")
_MODE = re.compile(r"[A-Z][A-Z0-9_]{0,15}")
_NAME = re.compile(r"[A-Za-z0-9_.\-]{1,32}")
#: A vehicle message's text: printable ASCII without ``,`` (or ``$``, ``*``: the frame's).
_TEXT = re.compile(r"[^,]{1,96}")
_TEXT_CHARS = 96
_FRAME = re.compile(rb"\$([\x20-\x23\x25-\x29\x2b-\x7e]*)\*([0-9A-Fa-f]{2})")

Value = int | float | str


def _number(lo: float, hi: float) -> Callable[[str], Value | None]:
    def parse(text: str) -> float | None:
        if not _NUMBER.fullmatch(text):
            return None
        value = float(text)
        return value if lo <= value <= hi else None
    return parse


def _integer(lo: int, hi: int) -> Callable[[str], Value | None]:
    def parse(text: str) -> int | None:
        if not _INTEGER.fullmatch(text):
            return None
        value = int(text)
        return value if lo <= value <= hi else None
    return parse


def _token(pattern: re.Pattern[str]) -> Callable[[str], Value | None]:
    return lambda text: text if pattern.fullmatch(text) else None


def _pwm(text: str) -> int | None:
    """An output [µs]: 0 (not driven) or 800…2200."""
    if not _INTEGER.fullmatch(text):
        return None
    value = int(text)
    return value if value == 0 or 800 <= value <= 2200 else None


_T_MS = _integer(0, 2**32 - 1)
_ROLL, _PITCH, _YAW = _number(-180, 180), _number(-90, 90), _number(-360, 360)
_RATE = _number(-2000, 2000)
_SPEED = _number(-20, 20)
_AXIS = _number(-1, 1)
_BOOL = _integer(0, 1)
_VERSION_FIELDS = (_integer(1, 999), _token(_NAME))

#: (talker, sentence id) → parsers of its fields; THR's outputs follow its count field.
_SPECS: dict[tuple[str, str], tuple[Callable[[str], Value | None], ...]] = {
    (VEHICLE, "ATT"): (_T_MS, _ROLL, _PITCH, _YAW, _RATE, _RATE, _RATE),
    (VEHICLE, "THR"): (_T_MS, _integer(1, MAX_OUTPUTS)),
    (VEHICLE, "DPT"): (_T_MS, _number(-10, 11_000)),
    (VEHICLE, "VEL"): (_T_MS, _SPEED, _SPEED, _SPEED),
    (VEHICLE, "BAT"): (_T_MS, _number(1, 100)),
    (VEHICLE, "STA"): (_T_MS, _token(_MODE), _BOOL, _token(re.compile("|".join(CONTROLS)))),
    (VEHICLE, "TXT"): (_T_MS, _integer(0, 7), _token(_TEXT)),
    (VEHICLE, "VER"): _VERSION_FIELDS,
    (TRIMD, "VER"): _VERSION_FIELDS,
    (TRIMD, "HBT"): (),
    (TRIMD, "HLD"): (_ROLL, _PITCH, _YAW),
    (TRIMD, "REL"): (),
    (TRIMD, "OPN"): (_AXIS,) * 6,
    (TRIMD, "ARM"): (_BOOL,),
}


@dataclass(frozen=True, slots=True)
class Sentence:
    """One checked sentence: talker (VH, TR), id (ATT, …) and its typed field values."""

    talker: str
    kind: str
    values: tuple[Value, ...]


@dataclass(frozen=True, slots=True)
class Version:
    """The version handshake (TRVER, VHVER): protocol version and the sender's name."""

    version: int
    name: str


@dataclass(frozen=True, slots=True)
class Heartbeat:
    """TRHBT: trimd is alive and commands nothing."""


def checksum(body: bytes) -> int:
    """XOR of the bytes between ``$`` and ``*``.

    >>> f"{checksum(b'TRHBT'):02X}"
    '58'
    """
    return reduce(xor, body, 0)


def encode(talker: str, kind: str, fields: Sequence[str]) -> bytes:
    """One framed sentence with its checksum and CR LF.

    >>> encode("TR", "ARM", ["1"])
    b'$TRARM,1*45\\r\\n'
    """
    body = ",".join([talker + kind, *fields]).encode("ascii")
    return b"$%s*%02X\r\n" % (body, checksum(body))


class LineParser:
    """Bytes in, checked sentences of one ``talker`` out; every dropped line counted.

    A line ends at LF (a CR before it is dropped; blank lines are ignored). In order, a
    line is ``too_long`` (≥ :data:`MAX_LINE_BYTES` before its LF), ``malformed`` (not
    ``$`` printable-ASCII ``*hh``), ``bad_checksum``, ``unknown`` (not a sentence this
    receiver takes), ``bad_fields`` (wrong field count) or ``bad_value`` (a field that is
    not a number/token of its kind or is out of its range); otherwise ``ok``.

    Attributes
    ----------
    counts : lines by outcome: ``ok`` and each of :data:`BAD_COUNTERS`.
    """

    def __init__(self, talker: str) -> None:
        self.talker = talker
        self.counts: Counter[str] = Counter()
        self._buffer = b""
        self._skipping = False

    @property
    def bad_lines(self) -> int:
        """Lines dropped so far."""
        return sum(self.counts[k] for k in BAD_COUNTERS)

    def feed(self, data: bytes) -> list[Sentence]:
        """The sentences completed by ``data`` (any chunking gives the same result)."""
        out: list[Sentence] = []
        buffer, start = self._buffer + data, 0
        while (end := buffer.find(b"\n", start)) >= 0:
            if self._skipping:
                self._skipping = False
            else:
                outcome = self._line(buffer[start:end])
                if isinstance(outcome, Sentence):
                    out.append(outcome)
                    self.counts["ok"] += 1
                elif outcome:
                    self.counts[outcome] += 1
            start = end + 1
        rest = buffer[start:]
        if not self._skipping and len(rest) >= MAX_LINE_BYTES:
            self.counts["too_long"] += 1
            self._skipping = True
        self._buffer = b"" if self._skipping else rest
        return out

    def _line(self, line: bytes) -> Sentence | str:
        """The sentence, or the counter that drops the line ("" for a blank line)."""
        if len(line) >= MAX_LINE_BYTES:
            return "too_long"
        if line.endswith(b"\r"):
            line = line[:-1]
        if not line:
            return ""
        frame = _FRAME.fullmatch(line)
        if frame is None:
            return "malformed"
        body = frame.group(1)
        if checksum(body) != int(frame.group(2), 16):
            return "bad_checksum"
        address, *fields = body.decode("ascii").split(",")
        key = (address[:2], address[2:])
        spec = _SPECS.get(key) if key[0] == self.talker else None
        if spec is None:
            return "unknown"
        if key[1] == "THR" and len(fields) >= 2:
            count = spec[1](fields[1])
            if not isinstance(count, int):
                return "bad_value"
            spec = spec + (_pwm,) * count
        if len(fields) != len(spec):
            return "bad_fields"
        values = [parse(text) for parse, text in zip(spec, fields, strict=True)]
        if any(v is None for v in values):
            return "bad_value"
        return Sentence(key[0], key[1], tuple(v for v in values if v is not None))


# ---------------------------------------------------------------------- conversions
def heading_deg(psi: float) -> float:
    """Yaw ψ [rad] as a compass heading in [0, 360) [deg].

    >>> heading_deg(-math.pi / 2)
    270.0
    """
    return math.degrees(psi) % 360.0


def _psi(yaw_deg: float) -> float:
    """Wire yaw [deg, any turn] → ψ [rad] in (−π, π]."""
    wrapped = (yaw_deg + 180.0) % 360.0 - 180.0
    return math.radians(180.0 if wrapped == -180.0 else wrapped)


def to_sample(s: Sentence, t_s: float, channels: Sequence[int]) -> Sample | Version | None:
    """The sample (SI, FRD/NED) a vehicle sentence carries, stamped ``t_s`` [s].

    ``channels`` are the profile thrusters' output channels (1-based) in profile order; a
    THR sentence that does not drive every one of them gives None. STA gives a connected
    :class:`Health`; the link decides what connected means.
    """
    v = s.values
    if s.kind == "ATT":
        phi, theta, yaw, p, q, r = (float(x) for x in v[1:])
        return Attitude(t_s, math.radians(phi), math.radians(theta), _psi(yaw),
                        math.radians(p), math.radians(q), math.radians(r))
    if s.kind == "THR":
        outputs = v[2:]
        pwm = tuple(float(outputs[c - 1]) if c <= len(outputs) else 0.0 for c in channels)
        return Thrusters(t_s, pwm) if all(pwm) else None
    if s.kind == "DPT":
        return Depth(t_s, float(v[1]))
    if s.kind == "VEL":
        return Velocity(t_s, float(v[1]), float(v[2]), float(v[3]))
    if s.kind == "BAT":
        return Battery(t_s, float(v[1]))
    if s.kind == "STA":
        return Health(t_s, True, str(v[1]), v[2] == 1, detail=f"control {v[3]}",
                      mode_class=mode_class(str(v[1])))
    if s.kind == "TXT":
        return VehicleText(t_s, int(v[1]), str(v[2]))
    return Version(int(v[0]), str(v[1]))


def to_command(s: Sentence) -> Command | Heartbeat | Version:
    """The command a trimd sentence carries (angles in rad)."""
    if s.kind == "VER":
        return Version(int(s.values[0]), str(s.values[1]))
    v = [float(x) for x in s.values]
    if s.kind == "HLD":
        return HoldAttitude(math.radians(v[0]), math.radians(v[1]), _psi(v[2]))
    if s.kind == "OPN":
        return OpenLoop((v[0], v[1], v[2], v[3], v[4], v[5]))
    if s.kind == "ARM":
        return Arm(v[0] == 1)
    if s.kind == "REL":
        return Release()
    return Heartbeat()


def _f(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    return "0" if float(text) == 0 else text   # never "-0.000"


def encode_sample(sample: Sample, t_ms: int, outputs: int = 0,
                  channels: Sequence[int] = (), control: str = "PILOT") -> bytes:
    """A vehicle sentence for ``sample`` (the simulator's side), vehicle clock ``t_ms``.

    Thrusters go out on ``outputs`` channels, thruster k on ``channels[k]``, the rest 0;
    Health becomes STA with ``control`` (one of :data:`CONTROLS`); a PilotInput has no
    sentence (ValueError: the pilot's takeover is STA's control PILOT). Values outside the
    protocol's ranges are clamped to them (a saturated sensor reads its full scale); a
    vehicle text is made to fit TXT (see below).
    """
    t = str(t_ms % 2**32)
    if isinstance(sample, Attitude):
        angles = (_clamp(math.degrees(sample.phi), 180), _clamp(math.degrees(sample.theta), 90),
                  heading_deg(sample.psi))
        rates = (_clamp(math.degrees(w), 2000) for w in (sample.p, sample.q, sample.r))
        return encode(VEHICLE, "ATT", [t, *(_f(a, 3) for a in angles),
                                       *(_f(w, 3) for w in rates)])
    if isinstance(sample, Thrusters):
        raw = ["0"] * outputs
        for c, pwm in zip(channels, sample.pwm_us, strict=True):
            raw[c - 1] = str(round(min(2200.0, max(800.0, pwm))))
        return encode(VEHICLE, "THR", [t, str(outputs), *raw])
    if isinstance(sample, Depth):
        return encode(VEHICLE, "DPT", [t, _f(_clamp(sample.depth_m, 11_000, -10), 3)])
    if isinstance(sample, Velocity):
        return encode(VEHICLE, "VEL", [t, *(_f(_clamp(x, 20), 3)
                                            for x in (sample.u, sample.v, sample.w))])
    if isinstance(sample, Battery):
        return encode(VEHICLE, "BAT", [t, _f(_clamp(sample.voltage_V, 100, 1), 2)])
    if isinstance(sample, Health):
        return encode(VEHICLE, "STA", [t, sample.mode, str(int(bool(sample.armed))), control])
    if isinstance(sample, PilotInput):
        raise ValueError("a pilot taking over is sent as STA with control PILOT, not as a "
                         "sentence of its own")
    if isinstance(sample, Confirmed):
        raise ValueError("a recording's confirmation mark is no vehicle sentence")
    # a text the protocol cannot carry is made to fit: other characters become "?",
    # commas ";", and it is cut to _TEXT_CHARS characters
    text = "".join(";" if c == "," else c if " " <= c <= "~" and c not in "$*" else "?"
                   for c in sample.text[:_TEXT_CHARS]) or " "
    return encode(VEHICLE, "TXT", [t, str(min(max(sample.severity, 0), 7)), text])


def _clamp(x: float, hi: float, lo: float | None = None) -> float:
    return min(hi, max(-hi if lo is None else lo, x))


def encode_command(command: Command | Heartbeat | Version) -> bytes:
    """A trimd sentence for ``command``; ValueError for values the protocol cannot carry
    (an open-loop input outside [−1, 1], a pitch beyond ±90°, NaN)."""
    if isinstance(command, HoldAttitude):
        roll, pitch = math.degrees(command.phi), math.degrees(command.theta)
        if not (abs(roll) <= 180 and abs(pitch) <= 90 and math.isfinite(command.psi)):
            raise ValueError(f"cannot hold roll {roll}°, pitch {pitch}°, yaw {command.psi} rad")
        return encode(TRIMD, "HLD", [_f(roll, 3), _f(pitch, 3),
                                     _f(heading_deg(command.psi), 3)])
    if isinstance(command, OpenLoop):
        if len(command.axes) != 6 or not all(abs(a) <= 1 for a in command.axes):
            raise ValueError(f"open-loop input must be 6 values in [-1, 1], got {command.axes}")
        return encode(TRIMD, "OPN", [_f(a, 3) for a in command.axes])
    if isinstance(command, Arm):
        return encode(TRIMD, "ARM", [str(int(command.armed))])
    if isinstance(command, Release):
        return encode(TRIMD, "REL", [])
    if isinstance(command, Heartbeat):
        return encode(TRIMD, "HBT", [])
    return encode(TRIMD, "VER", [str(command.version), command.name])
