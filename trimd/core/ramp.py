"""The commanded roll and pitch, moved to each new hold's at a limited rate.

A step of the attitude set-point lets the autopilot's attitude loop take the whole error
at once; on a vehicle whose thrusters idle in their dead band (the simulated small-payload
BlueROV2 Heavy at a step from level to 20°/20°) that overshot past 30°, beyond the
profile's tilt envelope, and the procedure had to stop. The ramp moves each axis at most
``procedure.tilt_rate_deg_s`` from where the command was (or, before the first, from the
attitude the vehicle had) to the hold's set-point; a move within the attitude tolerance
(``procedure.attitude_tol_deg``, on both axes) is commanded at once. Units: rad, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["TiltRamp"]


@dataclass
class TiltRamp:
    """Roll φ and pitch θ [rad] commanded now, on their way to ``target`` at no more than
    ``rate_rad_s`` per axis, or there at once from within ``tolerance_rad``; ``command``
    is None before the first :meth:`toward`."""

    rate_rad_s: float
    tolerance_rad: float
    command: tuple[float, float] | None = None
    _start: tuple[float, float] = (0.0, 0.0)
    _target: tuple[float, float] = (0.0, 0.0)
    _t0_s: float = math.nan

    def toward(self, t_s: float, target: tuple[float, float],
               now: tuple[float, float] | None) -> tuple[float, float]:
        """Start moving at ``t_s`` [s] to ``target``, from the command so far or, before
        the first, from ``now`` (the vehicle's attitude; ``target`` when unknown), or from
        ``target`` itself when that is within the tolerance; the command at ``t_s``."""
        start = self.command or now or target
        near = all(abs(s - g) <= self.tolerance_rad for s, g in zip(start, target, strict=True))
        self._start = target if near else start
        self._target, self._t0_s = target, t_s
        self.command = self._start
        return self.command

    def advance(self, t_s: float) -> bool:
        """Move the command to where the ramp is at ``t_s`` [s]; True when it moved."""
        if self.command is None or self.command == self._target:
            return False
        step = self.rate_rad_s * max(0.0, t_s - self._t0_s)
        moved = tuple(s + max(-step, min(step, g - s))
                      for s, g in zip(self._start, self._target, strict=True))
        if moved == self.command:
            return False
        self.command = (moved[0], moved[1])
        return True
