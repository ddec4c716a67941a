"""What trimd tells the people on the vehicle's network: short texts and named values.

A link that can put them where the pilot's ground station shows them (MAVLink: STATUSTEXT
and NAMED_VALUE_FLOAT, ``docs/mavlink.md``) implements :class:`trimd.core.link.Announces`;
the watch and the trim session hand it :class:`Text` and :class:`Values` and never wait
for them. They are not commands: nothing here asks the vehicle to do anything.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

__all__ = ["Announcement", "Severity", "Text", "Values"]


class Severity(IntEnum):
    """Syslog's severities (RFC 5424), which MAVLink's MAV_SEVERITY uses as they are:
    the smaller, the more urgent."""

    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7


@dataclass(frozen=True, slots=True)
class Text:
    """A line for people at ``severity``. Keep it short: a ground station shows 50
    characters at once (longer texts go out in pieces) and only ASCII reliably."""

    severity: Severity
    text: str

    @property
    def urgent(self) -> bool:
        """ALERT and more urgent: sent at once, outside any rate budget."""
        return self.severity <= Severity.CRITICAL


@dataclass(frozen=True, slots=True)
class Values:
    """Named numbers, each name at most 10 ASCII characters (``TRIMD_WB`` [N]); the
    units are the names' documented ones."""

    values: tuple[tuple[str, float], ...]

    def __post_init__(self) -> None:
        for name, _ in self.values:
            if not (0 < len(name) <= 10 and name.isascii()):
                raise ValueError(f"value name {name!r}: 1 to 10 ASCII characters")


Announcement = Text | Values
