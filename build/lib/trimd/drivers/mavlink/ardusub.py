"""ArduSub vehicle facts shared by the MAVLink driver, the recorder and the simulator."""

from __future__ import annotations

__all__ = ["MODES", "mode_name", "mode_number"]

#: HEARTBEAT.custom_mode of ArduSub (pymavlink's map lacks 20 and 21).
MODES: dict[int, str] = {
    0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 7: "CIRCLE",
    9: "SURFACE", 16: "POSHOLD", 19: "MANUAL", 20: "MOTOR_DETECT", 21: "SURFTRAK",
}
_NUMBERS = {name: number for number, name in MODES.items()}


def mode_name(number: int) -> str:
    """Name of an ArduSub mode number; ``MODE<n>`` for one this table does not know.

    Examples
    --------
    >>> mode_name(2), mode_name(42)
    ('ALT_HOLD', 'MODE42')
    """
    return MODES.get(number, f"MODE{number}")


def mode_number(name: str) -> int:
    """Inverse of :func:`mode_name` (``MODE<n>`` → n); ValueError for anything else."""
    if name in _NUMBERS:
        return _NUMBERS[name]
    if name.startswith("MODE") and name[4:].isdigit():
        return int(name[4:])
    raise ValueError(f"unknown ArduSub mode {name!r} (known: {', '.join(_NUMBERS)})")
