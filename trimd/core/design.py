"""Experiment design against the dead band: would one more hold decide the trim?

The thrust map near the dead band (docs/method.md §3) is uncertain by an ESC offset that
enters every hold with the same sign of thrust, so no choice of tilt removes it; but a
thruster that works on the *other* side of its band at another hold brings an independent
error there, and the mean of both is known better. The hold that does that for the
passive roll and pitch is the mirror of the tilted one, (−φ, −θ): its roll and pitch
moments from the stiffness change sign, so the vertical thrusters that carry them change
side, and its moment rows give the net moments about x and y again.

After the planned holds, when the proposal's passive trim is not known within the level
tolerance at 95 % and most of its variance is the band's, :func:`plan_extra_hold`
predicts the estimate with that mirrored hold: the last tilted hold's samples moved to
the mirrored attitude (τ shifted by G(−φ, −θ)·q̂ − G(φ, θ)·q̂, each thruster's thrust by
the minimum-norm allocation of that shift), so its noise and wander are today's. The hold
is added when the prediction decides the trim; otherwise the procedure stops and says by
how much the trim stays undecided. Units: rad, N, N·m.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trimd.core.errors import EstimationError
from trimd.core.estimate import HoldSamples, StaticEstimate, estimate_static, is_level
from trimd.core.model import restoring_matrix, thrust_configuration
from trimd.core.profile import Profile

__all__ = ["BAND_SHARE", "ExtraHold", "plan_extra_hold", "trim_spread_deg"]

#: The band's share of the passive trim's variance above which a hold is worth weighing.
BAND_SHARE = 0.5
_Z95 = 1.959964


@dataclass(frozen=True)
class ExtraHold:
    """The outcome of :func:`plan_extra_hold`.

    Attributes
    ----------
    roll_deg, pitch_deg : the mirrored hold's set-point [deg].
    now_deg : the passive roll/pitch's larger 95 % half-width [deg] from the holds so far.
    predicted_deg : the same with the mirrored hold added, as predicted [deg].
    add : whether the mirrored hold is predicted to decide the trim.
    message : what was chosen and why, for people.
    """

    roll_deg: float
    pitch_deg: float
    now_deg: float
    predicted_deg: float
    add: bool
    message: str


def trim_spread_deg(est: StaticEstimate) -> tuple[float, float]:
    """The 95 % half-width [deg] of the passive (roll, pitch) the estimate's net moments
    leave (σ of W·y_g − B·y_b and W·x_g − B·x_b over the stiffness W·z_g − B·z_b), and the
    dead band's share of their variance (the larger of the two). Infinite half-width when
    the stiffness is not positive."""
    k = float(est.q[3])
    if k <= 0:
        return math.inf, 0.0
    var = np.diag(est.q_cov)[1:3]
    band = np.diag(est.q_cov_band)[1:3] if est.q_cov_band is not None else np.zeros(2)
    spread = math.degrees(_Z95 * math.sqrt(float(var.max())) / k)
    share = float(np.max(np.divide(band, var, out=np.zeros(2), where=var > 0)))
    return spread, share


def plan_extra_hold(holds: Sequence[HoldSamples], est: StaticEstimate, profile: Profile,
                    level_tol_deg: float, setpoint_deg: tuple[float, float] | None = None
                    ) -> ExtraHold | None:
    """Weigh one more hold mirroring the last tilted one (module docstring), whose
    commanded (roll, pitch) was ``setpoint_deg`` (default its mean attitude). None when
    the trim is already decided, the band is not what keeps it from being decided, or
    there is no tilted hold to mirror."""
    now, share = trim_spread_deg(est)
    tilted = [h for h in holds if not is_level(h)]
    if now <= level_tol_deg or share < BAND_SHARE or not tilted or not profile.thrusters:
        return None
    last = tilted[-1]
    phi, theta = float(np.mean(last.phi)), float(np.mean(last.theta))
    shift = (restoring_matrix(-phi, -theta) - restoring_matrix(phi, theta)) @ est.q
    T = thrust_configuration(profile.thrusters)
    mirrored = HoldSamples(last.t_s, last.phi - 2 * phi, last.theta - 2 * theta,
                           last.tau + shift, "mirrored",
                           None if last.thrust is None else
                           last.thrust + np.linalg.pinv(T) @ shift)
    try:
        predicted, _ = trim_spread_deg(estimate_static([*holds, mirrored], profile))
    except EstimationError:
        return None
    roll, pitch = (-math.degrees(phi), -math.degrees(theta)) if setpoint_deg is None else (
        -setpoint_deg[0], -setpoint_deg[1])
    add = predicted <= level_tol_deg
    what = (f"the passive trim is known to ±{now:.2f}° at 95 % (tolerance ±{level_tol_deg:g}°), "
            f"{100 * share:.0f} % of its variance from thrusters at or near their dead band; "
            f"a hold at roll {roll:g}°, pitch {pitch:g}° (its vertical thrusters on the other "
            f"side of their band) is predicted to give ±{predicted:.2f}°")
    message = (f"{what}: adding it" if add else
               f"{what}, still wider than the tolerance: not adding it (only a calibration "
               "of the thrust map narrows it; after ballasting, a verify hold measures what "
               "is left)")
    return ExtraHold(roll, pitch, now, predicted, add, message)
