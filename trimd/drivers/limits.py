"""The drivers' own guard on what leaves trimd for a vehicle.

The procedure never asks for a hold beyond the profile's tilt limit (profiles are
validated so); this is the second line, in every driver that commands a real vehicle,
so that no other caller (a script, a future experiment, a bug) can tilt it further.
"""

from __future__ import annotations

import math

from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.samples import Command, HoldAttitude

__all__ = ["check_command"]


def check_command(command: Command, profile: Profile) -> None:
    """Raise LinkError for a hold that is not finite or is beyond ``max_tilt_deg``
    (per axis, roll and pitch, as the profile's holds are checked).

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> p = load_profile("bluerov2-heavy")
    >>> check_command(HoldAttitude(math.radians(20), math.radians(-20), 0.0), p)
    >>> check_command(HoldAttitude(math.radians(30), 0.0, 0.0), p)
    Traceback (most recent call last):
    ...
    trimd.core.errors.LinkError: not sent: a hold at roll 30.0°, pitch 0.0° is beyond ...
    """
    if not isinstance(command, HoldAttitude):
        return
    angles = (command.phi, command.theta, command.psi)
    if not all(math.isfinite(a) for a in angles):
        raise LinkError(f"not sent: a hold with a non-finite angle {angles}")
    roll, pitch = math.degrees(command.phi), math.degrees(command.theta)
    limit = profile.procedure.max_tilt_deg
    if max(abs(roll), abs(pitch)) > limit + 1e-9:
        raise LinkError(f"not sent: a hold at roll {roll:.1f}°, pitch {pitch:.1f}° is beyond "
                        f"the profile's max_tilt_deg ({limit:g}°)")
