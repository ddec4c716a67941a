"""A float as an absolute reference for the thrust map (docs/method.md §7).

A calibration experiment compares two level holds, so whatever moves the thrust of both
alike cancels: an ESC's dead band offset by b moves the straight stretch of its curve
beyond the band, and every output on it delivers slope × b more or less thrust in both
holds. On the vertical thrusters that is indistinguishable from another net moment, and a
calibration cannot learn it.

A float is a hold with every output at neutral PWM: no thrust whatever the curves. With
the vehicle unchanged between a level hold and the float right after it (no piece moved),
the float's roll φ_f and pitch θ_f fix the net moments from the stiffness q_z = W·z_g −
B·z_b (:func:`trimd.core.model.restoring_matrix`: its K and M rows vanish at the float)

    W·y_g − B·y_b = q_z·tan φ_f,     W·x_g − B·x_b = −q_z·tan θ_f / cos φ_f,

and so the level hold's K and M, G(φ, θ)·q on those rows, without any thrust map: a
target no difference of holds has. As an experiment (:class:`FloatReference`,
:func:`reference_model`) it is the change from the float, its outputs all at neutral, to
the hold: the same fit (:mod:`trimd.core.thrust_fit`) and the same check
(:mod:`trimd.core.calibration`) as any other. Its covariance carries the float's attitude
± (which includes the attitude reference's error), q_z's, the hold's noise and wander,
its attitude reference's error and what its hunting samples delivered.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from trimd.core.errors import EstimationError
from trimd.core.estimate import LEVEL_RAD, measurable_dofs
from trimd.core.floating import FloatResult
from trimd.core.model import restoring_matrix, thrust_configuration
from trimd.core.output_hist import OutputHistogram, spikes_seen
from trimd.core.profile import Profile
from trimd.core.systematics import exposure_factors, hold_error_cov
from trimd.core.thrust_fit import ChangeModel
from trimd.core.types import FloatArray

if TYPE_CHECKING:
    from trimd.core.calibration import CalibrationHold

__all__ = ["FloatReference", "float_moments", "float_reference", "reference_model"]

#: The rows of τ a float fixes at a level hold: K, M.
ROWS = np.array([False, False, False, True, True, False])
#: Relative step of the finite differences that carry the float's ± into the target.
_STEP = 1e-6


@dataclass(frozen=True, eq=False)
class FloatReference:
    """A level hold and the float of the same vehicle right after it.

    Attributes
    ----------
    label : for people ("calibration 4: hold 1 → float").
    hold : the level hold (:class:`trimd.core.calibration.CalibrationHold`).
    phi_rad, theta_rad : the float's mean roll and pitch [rad].
    angle_cov : their covariance, shape (2, 2) [rad²] (the float's ±, attitude reference
        included).
    q_z, q_z_var : the stiffness W·z_g − B·z_b [N·m] (a trim's estimate, or the
        profile's nominal vehicle) and its variance [N²·m²].
    """

    label: str
    hold: CalibrationHold
    phi_rad: float
    theta_rad: float
    angle_cov: FloatArray
    q_z: float
    q_z_var: float

    @property
    def change(self) -> tuple[()]:
        """No ballast changes between the hold and the float."""
        return ()


def float_reference(label: str, hold: CalibrationHold, floated: FloatResult, q_z: float,
                    q_z_var: float) -> FloatReference:
    """The reference of ``hold`` and the float check ``floated`` after it: its mean roll
    and pitch and their 1σ as the float measured them, the stiffness ``q_z`` [N·m] and
    its variance [N²·m²]."""
    return FloatReference(label, hold, math.radians(floated.roll_deg),
                          math.radians(floated.pitch_deg),
                          np.diag(np.radians([floated.roll_std_deg,
                                              floated.pitch_std_deg]) ** 2), q_z, q_z_var)


def float_moments(phi_rad: float, theta_rad: float, q_z: float) -> FloatArray:
    """q = [0, W·x_g − B·x_b, W·y_g − B·y_b, q_z] [N, N·m] of a vehicle that floats at
    roll ``phi_rad`` and pitch ``theta_rad`` with stiffness ``q_z`` (module docstring;
    W − B, which the float does not show, as 0: no row a float fixes has it).

    Examples
    --------
    >>> q = float_moments(0.02, -0.01, 4.0)
    >>> np.round(restoring_matrix(0.02, -0.01)[3:5] @ q, 12)   # no restoring moment
    array([0., 0.])
    """
    return np.array([0.0, -q_z * math.tan(theta_rad) / math.cos(phi_rad),
                     q_z * math.tan(phi_rad), q_z])


def reference_model(ref: FloatReference, profile: Profile) -> ChangeModel:
    """``ref`` as the fit and the check see it: the change of τ on K and M from the float
    (every output at neutral, no thrust) to the hold. EstimationError when the hold is not
    level or its thrusters are not the profile's."""
    hold = ref.hold
    if max(abs(hold.phi_rad), abs(hold.theta_rad)) >= LEVEL_RAD:
        raise EstimationError(f"float reference {ref.label!r}: hold {hold.label!r} is not "
                              "level (a float is compared with a level hold)")
    if hold.exposure.shape != (4 * len(profile.thrusters),):
        raise EstimationError(f"float reference {ref.label!r}: hold {hold.label!r} has "
                              f"{len(hold.exposure) // 4} thrusters, the profile "
                              f"{len(profile.thrusters)}")
    r = ROWS & np.array(measurable_dofs(profile), bool)
    G = restoring_matrix(hold.phi_rad, hold.theta_rad)[r]

    def target(x: FloatArray) -> FloatArray:
        out: FloatArray = G @ float_moments(x[0], x[1], x[2])
        return out

    x0 = np.array([ref.phi_rad, ref.theta_rad, ref.q_z])
    cov = np.zeros((3, 3))
    cov[:2, :2], cov[2, 2] = ref.angle_cov, ref.q_z_var
    steps = _STEP * np.maximum(np.abs(x0), 1.0)
    D = np.column_stack([(target(x0 + h * e) - target(x0 - h * e)) / (2 * h)
                         for h, e in zip(steps, np.eye(3), strict=True)])
    q = float_moments(*x0)
    spikes = () if hold.outputs is None else tuple(spikes_seen(hold.outputs, profile))
    R = (hold.tau_cov[np.ix_(r, r)] + D @ cov @ D.T
         + hold_error_cov(hold.phi_rad, hold.theta_rad, r, profile, q, spikes))
    neutral = None if hold.outputs is None else OutputHistogram(
        tuple(np.array([t.curve.neutral_us]) for t in profile.thrusters),
        tuple(np.ones(1) for _ in profile.thrusters), hold.outputs.voltage_V)
    return ChangeModel(ref.label, r, target(x0), R, thrust_configuration(profile.thrusters)[r],
                       neutral, hold.outputs, hold.tau[r],
                       exposure_factors(hold.exposure, r, profile), ((), spikes))
