"""A serial vehicle's mode tokens (the ``mode`` of its STA sentence) and what they do
(docs/serial-protocol.md, "Modes")."""

from __future__ import annotations

from trimd.core.samples import ModeClass

__all__ = ["MODE_CLASSES", "mode_class"]

#: What the mode tokens of STA mean (docs/serial-protocol.md, "Modes"): ArduSub's names
#: with ArduSub's meaning (a recording stores the mode as ArduSub's number, so a
#: token spelled as an ArduSub mode must mean what that mode does); any other token is
#: :attr:`~trimd.core.samples.ModeClass.UNKNOWN`.
MODE_CLASSES: dict[str, ModeClass] = {
    "MANUAL": ModeClass.MANUAL, "ACRO": ModeClass.MANUAL,
    "STABILIZE": ModeClass.STABILISED,
    "ALT_HOLD": ModeClass.DEPTH_HOLDING, "POSHOLD": ModeClass.DEPTH_HOLDING,
    "AUTO": ModeClass.AUTONOMOUS, "GUIDED": ModeClass.AUTONOMOUS,
    "CIRCLE": ModeClass.AUTONOMOUS, "SURFTRAK": ModeClass.AUTONOMOUS,
    "SURFACE": ModeClass.FAILSAFE,
    "MOTOR_DETECT": ModeClass.SERVICE,
}


def mode_class(token: str) -> ModeClass:
    """What the mode ``token`` does (UNKNOWN for a token not in :data:`MODE_CLASSES`).

    Examples
    --------
    >>> mode_class("ALT_HOLD"), mode_class("MY_MODE")
    (<ModeClass.DEPTH_HOLDING: 'depth-holding'>, <ModeClass.UNKNOWN: 'unknown'>)
    """
    return MODE_CLASSES.get(token, ModeClass.UNKNOWN)
