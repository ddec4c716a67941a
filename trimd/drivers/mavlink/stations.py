"""The other ground stations seen through the link, and their pilots' stick input.

On a BlueOS setup every ground station (QGroundControl with the pilot's joystick, MAVProxy,
trimd) reaches the autopilot through one router, and the router passes each station's
packets to the others. :class:`Stations` keeps the GCS heartbeats (MAV_TYPE_GCS) that are
not trimd's own, so the link knows whether it is the only ground station: ArduSub takes
pilot input (MANUAL_CONTROL) from any of them and the last one wins, so trimd must not
send neutral sticks beside a pilot's station (``docs/mavlink.md``).

A heartbeat carrying trimd's own system and component id also counts: a router never
sends a station's packets back to it, so it can only come from another station
configured with the same ids (QGroundControl and trimd both default to 255/190).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from trimd.drivers.mavlink.message import MavMessage

__all__ = ["STATION_TIMEOUT_S", "STICK_THRESHOLD", "Stations", "stick_deflection"]

#: A station is gone after this long [s] without its heartbeat (three missed 1 Hz beats).
STATION_TIMEOUT_S = 3.0
#: Stick input beyond this fraction of full deflection from neutral is a pilot flying.
STICK_THRESHOLD = 0.1

_TYPE_GCS = 6
_UNUSED = 0x7FFF            # INT16_MAX: "this axis is not used" in MANUAL_CONTROL
_Z_NEUTRAL = 500            # ArduSub: throttle z in 0..1000, 500 is neutral


def stick_deflection(msg: MavMessage) -> float:
    """The largest deflection from neutral, as a fraction of full travel, of one
    MANUAL_CONTROL message: x, y, r in ±1000 around 0, z in 0..1000 around 500, and the
    extension axes s (pitch) and t (roll) when ``enabled_extensions`` says they are used.
    Unused axes (INT16_MAX) count as neutral.

    Examples
    --------
    >>> from pymavlink.dialects.v20 import ardupilotmega as m
    >>> stick_deflection(m.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0))
    0.0
    >>> stick_deflection(m.MAVLink_manual_control_message(1, 150, 0, 250, 0x7FFF, 0))
    0.5
    """
    axes = [abs(int(msg.x)) / 1000, abs(int(msg.y)) / 1000, abs(int(msg.r)) / 1000,
            abs(int(msg.z) - _Z_NEUTRAL) / _Z_NEUTRAL]
    raw = [int(msg.x), int(msg.y), int(msg.r), int(msg.z)]
    ext = int(getattr(msg, "enabled_extensions", 0) or 0)
    for bit, name in ((0b01, "s"), (0b10, "t")):
        if ext & bit:
            raw.append(int(getattr(msg, name)))
            axes.append(abs(int(getattr(msg, name))) / 1000)
    return max((a for a, r in zip(axes, raw, strict=True) if r != _UNUSED), default=0.0)


@dataclass
class Stations:
    """Other ground stations by (system id, component id), from their heartbeats.

    Parameters
    ----------
    own : trimd's own (system id, component id).
    """

    own: tuple[int, int]
    seen: dict[tuple[int, int], float] = field(default_factory=dict)  # → last beat [s]

    def heartbeat(self, msg: MavMessage, now: float) -> tuple[int, int] | None:
        """Note a HEARTBEAT received at ``now`` [s]; the sender when it is a ground station
        not seen before (or back after :data:`STATION_TIMEOUT_S`), else None."""
        if int(msg.type) != _TYPE_GCS:
            return None
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        last = self.seen.get(source)
        self.seen[source] = now
        return source if last is None or now - last > STATION_TIMEOUT_S else None

    def heard(self, source: tuple[int, int], now: float) -> None:
        """Any packet from a known station at ``now`` [s] shows it is still there (its
        heartbeats may be lost on a busy link while its stick input arrives)."""
        if source in self.seen:
            self.seen[source] = max(self.seen[source], now)

    def present(self, now: float) -> list[tuple[int, int]]:
        """The stations whose heartbeat was heard within :data:`STATION_TIMEOUT_S`."""
        return sorted(s for s, t in self.seen.items() if now - t <= STATION_TIMEOUT_S)

    def gone(self, now: float) -> list[tuple[int, int]]:
        """Stations silent for longer than :data:`STATION_TIMEOUT_S`, forgotten now."""
        out = sorted(s for s, t in self.seen.items() if now - t > STATION_TIMEOUT_S)
        for s in out:
            del self.seen[s]
        return out

    def stick_input(self, msg: MavMessage, vehicle_sysid: int) -> str | None:
        """Words for the operator when a MANUAL_CONTROL to the vehicle deflects a stick
        beyond :data:`STICK_THRESHOLD` (someone is flying), else None."""
        if int(msg.target) not in (0, vehicle_sysid):
            return None
        deflection = stick_deflection(msg)
        if deflection <= STICK_THRESHOLD:
            return None
        return (f"stick input from sysid {msg.get_srcSystem()} "
                f"({deflection:.0%} of full deflection)")

    def describe(self, source: tuple[int, int]) -> str:
        """E.g. ``"ground station sysid 255 component 190"`` (and a note for trimd's ids)."""
        text = f"ground station sysid {source[0]} component {source[1]}"
        if source == self.own:
            text += " (trimd's own ids: give trimd another one with gcs=N)"
        return text
