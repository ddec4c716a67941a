"""The correction after a verify hold: what to change on the ballast installed now so that
the vehicle floats level, from what the verify hold measured.

The verify hold measured the ballasted vehicle at level: W − B and the net moments
W·x_g − B·x_b and W·y_g − B·y_b [N, N·m; body FRD, origin CG0] with their covariance
(:class:`trimd.ballast.verify.Verification`). At level the stiffness W·z_g − B·z_b does
not show; it is the prediction's (the trim's estimate plus the pieces installed since,
whose weights and positions are known), with the trim's variance. Those four are the
vehicle as it is now, with its ballast on (:func:`measured_vehicle`): an estimate like a
trim's, whose roll and pitch rows are the verify hold's, whose ± is mostly the verify
hold's (its thrusters barely work, so the thrust curves' errors hardly enter).

A float check (:mod:`trimd.core.float_check`) measures the same vehicle without the
thrust map: the attitude it floats at, at which W·r_g − B·r_b points along gravity, two
equations that update the prediction (:func:`floated_vehicle`): the x/y net moments to
the attitude reference's accuracy, and W·z_g − B·z_b as far as the trim's covariance ties
its error to theirs.

The correction is :func:`trimd.ballast.propose.propose_ballast`'s ``milp`` proposal for
that vehicle from the ballast installed now: the same inventory, slots, net-buoyancy
window, aim inside the level tolerance by the 95 % interval, pieces moved, removed or
added, physics check, and ± of the passive trim it leaves (from the measured covariance
and the stiffness's).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from trimd.ballast.check import SlotLoad, check_trim
from trimd.ballast.proposal import Proposal, proposal_to_dict
from trimd.ballast.propose import propose_ballast
from trimd.ballast.verify import Verification
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.floating import FloatResult
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.static_estimate import HoldSummary, StaticEstimate, net_estimate

__all__ = ["Correction", "correction_to_dict", "floated_vehicle", "measured_vehicle",
           "needs_correction", "propose_correction", "propose_float_correction"]

#: The rows a level hold measures each net quantity by: Z → W − B, M → W·x_g − B·x_b,
#: K → W·y_g − B·y_b (for the estimate's ``dofs_used``).
_LEVEL_ROWS = ("Z", "M", "K")
#: χ² (2 degrees of freedom) beyond which a float contradicts the prediction (0.1 %).
_FLOAT_CONSISTENT = 13.8


@dataclass(frozen=True, eq=False)
class Correction:
    """A verify hold's correction.

    Attributes
    ----------
    vehicle : the vehicle as the verify hold measured it, with the ballast installed then
        (:func:`measured_vehicle`).
    proposal : the ``milp`` proposal for ``vehicle`` from that ballast: its changes are
        what to move, remove and add; its trim the passive trim they leave (± 1σ).
    """

    vehicle: StaticEstimate
    proposal: Proposal


def needs_correction(v: Verification) -> bool:
    """A correction is proposed when the verify hold found the vehicle not level within the
    profile's tolerance, or not as its prediction said."""
    return not (v.level and v.as_predicted)


def measured_vehicle(v: Verification, estimate: StaticEstimate, profile: Profile
                     ) -> StaticEstimate:
    """The vehicle as it is now, ballast on, from the verify hold ``v`` of the trim
    ``estimate`` (module docstring): q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b,
    W·z_g − B·z_b] [N, N·m] with its covariance.

    When the hold found the vehicle as predicted, the prediction (``v.predicted``: the
    trim's estimate plus the pieces installed since, exactly known, so with
    ``estimate``'s covariance) and the hold's measurement of the rows it observes are two
    independent measurements of the same vehicle, and q is their minimum-variance
    combination (a Kalman update of the prediction by the hold; W·z_g − B·z_b, not seen at
    level, moves with its covariance to the rest). When it did not, the prediction is not
    trusted: the three rows are the hold's alone and W·z_g − B·z_b the prediction's, with
    ``estimate``'s variance, uncorrelated with the rest."""
    m = v.measured
    predicted = np.r_[-v.predicted.net_buoyancy_N, v.predicted.net_moment_Nm]
    if v.as_predicted:
        seen = np.flatnonzero(m.observable[:3])
        H = np.eye(4)[seen]
        S = H @ estimate.q_cov @ H.T + m.q_cov[np.ix_(seen, seen)]
        K = np.linalg.solve(S, H @ estimate.q_cov).T
        q = predicted + K @ (m.q[seen] - predicted[seen])
        q_cov = estimate.q_cov - K @ S @ K.T
        q_cov = (q_cov + q_cov.T) / 2
        how = ("W − B and the x/y net moments measured at level combined with the "
               "prediction (the trim and the pieces installed since), as predicted")
    else:
        q = np.r_[m.q[:3], predicted[3]]
        q_cov = np.zeros((4, 4))
        q_cov[:3, :3] = m.q_cov[:3, :3]
        q_cov[3, 3] = estimate.q_cov[3, 3]
        how = ("W − B and the x/y net moments measured at level (NOT as predicted: the "
               "prediction left out)")
    hold = HoldSummary("verify", m.roll_deg, m.pitch_deg, m.samples, m.t_start_s,
                       m.t_end_s, resolved=m.resolved)
    note = (f"the vehicle as a verify hold measured it, its ballast on: {how}; "
            "W·z_g − B·z_b (not observable at level) from the trim and the pieces "
            "installed since")
    return net_estimate(q, q_cov, profile, holds=(hold,),
                        dofs_used=tuple(r for r, o in zip(_LEVEL_ROWS, m.observable[:3],
                                                          strict=True) if o),
                        residual_rms=np.full(6, np.nan), notes=(note,))


def floated_vehicle(f: FloatResult, estimate: StaticEstimate, loads: Sequence[SlotLoad],
                    profile: Profile) -> StaticEstimate:
    """The vehicle as the float check ``f`` found it, its ballast on: q = [W − B,
    W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] [N, N·m] (body FRD, origin CG0).

    At the attitude (φ, θ) it floats at, the restoring moment (W·r_g − B·r_b) × g_b
    vanishes, g_b = (−sin θ, cos θ·sin φ, cos θ·cos φ) the direction of gravity in the
    body (Fossen eq. 4.6): W·r_g − B·r_b = λ·g_b, i.e. m_x + m_z·tan θ / cos φ = 0 and
    m_y − m_z·tan φ = 0, two equations linear in q. The prediction (the trim ``estimate``
    plus ``loads``, the pieces installed since, exactly known: ``estimate``'s covariance)
    is updated by them as by a measurement (a Kalman update; the float's 1σ in φ and θ
    through the Jacobian at the prediction's m_z): the x/y net moments come out of the
    float, and whatever of the trim's errors they share with W·z_g − B·z_b and W − B
    (the thrust curves' gains move the tilted hold's stiffness and the level hold's
    moments alike) is corrected in those too, so that the stiffness a correction divides
    by is as good as the float and the known ballast change make it. When the float
    contradicts the prediction beyond chance (χ² of 2 degrees of freedom past
    :data:`_FLOAT_CONSISTENT`), the prediction's errors are not what its covariance says:
    m_x and m_y are the float's alone and W − B and m_z the prediction's."""
    predicted = check_trim(estimate, loads, profile.gravity_m_s2)
    q_p = np.r_[-predicted.net_buoyancy_N, predicted.net_moment_Nm]
    P = estimate.q_cov
    m_z = float(q_p[3])
    phi, theta = math.radians(f.roll_deg), math.radians(f.pitch_deg)
    t_phi, t_theta, c_phi = math.tan(phi), math.tan(theta), math.cos(phi)
    H = np.array([[0.0, 1.0, 0.0, t_theta / c_phi], [0.0, 0.0, 1.0, -t_phi]])
    J = np.array([[m_z * t_theta * t_phi / c_phi, m_z / (c_phi * math.cos(theta)**2)],
                  [-m_z / c_phi**2, 0.0]])   # ∂(H q) / ∂(φ, θ)
    angle_cov = np.diag([math.radians(f.roll_std_deg)**2, math.radians(f.pitch_std_deg)**2])
    R = J @ angle_cov @ J.T
    S = H @ P @ H.T + R
    innovation = -H @ q_p
    if float(innovation @ np.linalg.solve(S, innovation)) <= _FLOAT_CONSISTENT:
        K = np.linalg.solve(S, H @ P).T
        q = q_p + K @ innovation
        q_cov = P - K @ S @ K.T
        how = ("updated by the attitude it floats at (no thrust map), as predicted: W − B "
               "and W·z_g − B·z_b corrected with the x/y net moments")
    else:
        q = np.r_[q_p[0], -m_z * t_theta / c_phi, m_z * t_phi, m_z]
        G = np.zeros((4, 4))   # ∂q / ∂(W − B, m_z, φ, θ)
        G[0, 0] = G[3, 1] = 1.0
        G[1] = (0.0, -H[0, 3], -J[0, 0], -J[0, 1])
        G[2] = (0.0, t_phi, -J[1, 0], 0.0)
        cov = np.zeros((4, 4))
        cov[:2, :2] = P[np.ix_((0, 3), (0, 3))]
        cov[2:, 2:] = angle_cov
        q_cov = G @ cov @ G.T
        how = ("the x/y net moments from the attitude it floats at (no thrust map; NOT as "
               "predicted: the prediction left out), W − B and W·z_g − B·z_b the "
               "prediction's")
    note = (f"the vehicle as a float check found it, its ballast on: {how} (the trim and "
            "the pieces installed since)")
    hold = HoldSummary("float", f.roll_deg, f.pitch_deg, f.samples, f.t_start_s, f.t_end_s)
    return net_estimate(q, (q_cov + q_cov.T) / 2, profile, holds=(hold,),
                        dofs_used=("K", "M"), residual_rms=np.full(6, np.nan), notes=(note,))


def propose_correction(v: Verification, estimate: StaticEstimate, profile: Profile,
                       installed: Sequence[InstalledPiece]) -> Correction:
    """The correction of the ballast ``installed`` now (what the verify hold ``v`` of the
    trim ``estimate`` measured with on the vehicle), by the ``milp`` proposal for the
    measured vehicle. ProfileError when ``installed`` is not ``profile``'s."""
    vehicle = measured_vehicle(v, estimate, profile)
    return Correction(vehicle, propose_ballast(vehicle, profile, "milp", installed=installed))


def propose_float_correction(f: FloatResult, estimate: StaticEstimate,
                             loads: Sequence[SlotLoad], profile: Profile,
                             installed: Sequence[InstalledPiece]) -> Correction:
    """The correction of the ballast ``installed`` now, for the vehicle as the float
    check ``f`` found it (:func:`floated_vehicle` of the trim ``estimate`` with ``loads``
    installed since), by the ``milp`` proposal."""
    vehicle = floated_vehicle(f, estimate, loads, profile)
    return Correction(vehicle, propose_ballast(vehicle, profile, "milp", installed=installed))


def correction_to_dict(c: Correction | None) -> dict[str, Any]:
    """JSON-ready: ``needed`` and, when it is, the measured vehicle (``estimate``, the
    ``trimd solve --json`` shape) and the correction (``proposal``, the ``trimd ballast
    --json`` shape): what ``trimd ballast apply --estimate`` and ``trimd run --verify``
    read back."""
    if c is None:
        return {"needed": False, "estimate": None, "proposal": None,
                "message": "no correction needed: level and as predicted"}
    return {"needed": True, "estimate": estimate_to_dict(c.vehicle),
            "proposal": proposal_to_dict(c.proposal), "message": c.proposal.message}
