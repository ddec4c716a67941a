"""ArduSub vehicle facts shared by the MAVLink driver, the recorder and the simulator."""

from __future__ import annotations

from trimd.core.samples import ModeClass

__all__ = ["MODES", "MODE_CLASSES", "mode_class", "mode_class_of", "mode_name", "mode_number"]

#: HEARTBEAT.custom_mode of ArduSub (pymavlink's map lacks 20 and 21).
MODES: dict[int, str] = {
    0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 7: "CIRCLE",
    9: "SURFACE", 16: "POSHOLD", 19: "MANUAL", 20: "MOTOR_DETECT", 21: "SURFTRAK",
}
_NUMBERS = {name: number for number, name in MODES.items()}
#: What each ArduSub mode does (docs/ardusub.md, "Modes"); a number not listed is
#: :attr:`ModeClass.UNKNOWN`.
MODE_CLASSES: dict[int, ModeClass] = {
    0: ModeClass.STABILISED,       # STABILIZE
    1: ModeClass.MANUAL,           # ACRO: the autopilot holds body rates, not an attitude
    2: ModeClass.DEPTH_HOLDING,    # ALT_HOLD
    3: ModeClass.AUTONOMOUS,       # AUTO
    4: ModeClass.AUTONOMOUS,       # GUIDED
    7: ModeClass.AUTONOMOUS,       # CIRCLE
    9: ModeClass.FAILSAFE,         # SURFACE
    16: ModeClass.DEPTH_HOLDING,   # POSHOLD
    19: ModeClass.MANUAL,          # MANUAL
    20: ModeClass.SERVICE,         # MOTOR_DETECT
    21: ModeClass.AUTONOMOUS,      # SURFTRAK: the depth follows the seafloor, not the pilot
}


def mode_class(number: int) -> ModeClass:
    """What ArduSub mode ``number`` does; UNKNOWN for one this table does not know.

    Examples
    --------
    >>> mode_class(2), mode_class(42)
    (<ModeClass.DEPTH_HOLDING: 'depth-holding'>, <ModeClass.UNKNOWN: 'unknown'>)
    """
    return MODE_CLASSES.get(number, ModeClass.UNKNOWN)


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


def mode_class_of(name: str) -> ModeClass:
    """What the ArduSub mode named ``name`` does (``MODE<n>`` as n); UNKNOWN for a name
    ArduSub does not have."""
    try:
        return mode_class(mode_number(name))
    except ValueError:
        return ModeClass.UNKNOWN
