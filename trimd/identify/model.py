"""The grey-box model of dynamic identification: named parameters and a batched simulator.

Fossen's 6-DOF model (docs/method.md §2) with a diagonal mass matrix about CG0,

    M·ν̇ + C(ν)·ν + D(ν)·ν + g(η) = τ_f,     M = diag(M_u, M_v, M_w, M_p, M_q, M_r),

where M_u = m + X_u̇ (likewise v, w; added masses as positive magnitudes) and
M_p = I_x + K_ṗ (likewise q, r: only the sums are identifiable), the Coriolis and
centripetal terms of rigid body and added mass together in Kirchhoff form
C(ν)·ν = [ω × (M₁·v); ω × (M₂·ω) + v × (M₁·v)] (Fossen eq. 3.56, 6.43: the same physics
as ``trimd.drivers.sim.dynamics``; with r_g = 0 the Coriolis combinations such as the Munk
moment (M_v − M_u)·u·v follow from the six mass entries), diagonal linear plus quadratic
damping (Fossen's negative derivatives), the restoring forces of the profile (or a static
estimate) through :func:`trimd.core.model.restoring_matrix`, and the thrust τ_f of the
thrusters' commanded τ through a first-order spin-up lag of time constant T_thr [s].

The state is x = [u, v, w, p, q, r, φ, θ] (body FRD velocities [m/s, rad/s], roll and
pitch [rad]); yaw does not enter the dynamics. A stage simulates the states of the degrees
of freedom it excites and takes the others from the measurements (exogenous inputs).

The simulator is written for least squares: it integrates many short segments at once
(axis K) for many parameter vectors at once (axis B, the finite-difference columns of a
Jacobian), with classical RK4 at the sample interval h and τ_f exact for a zero-order-held
command.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trimd.core.estimate import StaticEstimate
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

__all__ = [
    "DVL_DOFS",
    "HYDRO_NAMES",
    "LAG",
    "LEAD",
    "STAGES",
    "STATE_NAMES",
    "Stage",
    "Statics",
    "lagged_thrust",
    "observed",
    "prior_values",
    "restoring_vector",
    "simulate",
    "statics_from_estimate",
    "statics_of_profile",
]


#: State components, in order.
STATE_NAMES = ("u", "v", "w", "p", "q", "r", "phi", "theta")
_MASS = ("X_udot", "Y_vdot", "Z_wdot", "I_x+K_pdot", "I_y+M_qdot", "I_z+N_rdot")
_LIN = ("X_u", "Y_v", "Z_w", "K_p", "M_q", "N_r")
_QUAD = ("X_u|u|", "Y_v|v|", "Z_w|w|", "K_p|p|", "M_q|q|", "N_r|r|")
#: The 18 hydrodynamic parameters: added mass (surge, sway, heave) or inertia sum (roll,
#: pitch, yaw) per DOF, then the linear and the quadratic damping derivatives.
HYDRO_NAMES = _MASS + _LIN + _QUAD
#: Name of the thruster spin-up time constant [s].
LAG = "T_thr"
#: Name of the lead of the thruster record over the motion record [s] (lagged_thrust).
LEAD = "T_lead"


@dataclass(frozen=True, slots=True)
class Stage:
    """One excitation stage (docs/method.md §5).

    Attributes
    ----------
    name : uvr, uwq or uvwpqr.
    dofs : excited degrees of freedom (0..5 = u, v, w, p, q, r): their parameters are free.
    states : simulated state components (indices into :data:`STATE_NAMES`).
    axes : open-loop axes the experiment drives (0..5 = surge, sway, heave, roll, pitch,
        yaw).
    """

    name: str
    dofs: tuple[int, ...]
    states: tuple[int, ...]
    axes: tuple[int, ...]

    @property
    def outputs(self) -> tuple[int, ...]:
        """Compared outputs: every simulated state."""
        return self.states

    @property
    def free_names(self) -> tuple[str, ...]:
        """Hydrodynamic parameters this stage estimates."""
        return tuple(n for group in (_MASS, _LIN, _QUAD) for i, n in enumerate(group)
                     if i in self.dofs)

    def restricted(self, dofs: tuple[int, ...]) -> Stage:
        """This stage with only the DOFs of ``dofs`` fitted and simulated; the other
        velocities and angles are taken from the measurements (roll angle with roll, pitch
        angle with pitch)."""
        kept = tuple(d for d in self.dofs if d in dofs)
        angles = tuple(a for a, dof in ((6, 3), (7, 4)) if dof in kept and a in self.states)
        return Stage(self.name, kept, tuple(s for s in self.states if s in kept) + angles,
                     self.axes)


#: The DOFs only a DVL observes (surge, sway); without one, the gyro and attitude observe
#: roll, pitch and yaw and the depth sensor heave.
DVL_DOFS = (0, 1)

STAGES = {
    "uvr": Stage("uvr", (0, 1, 5), (0, 1, 5), (0, 1, 5)),
    "uwq": Stage("uwq", (0, 2, 4), (0, 2, 4, 7), (0, 2, 4)),
    "uvwpqr": Stage("uvwpqr", (0, 1, 2, 3, 4, 5), tuple(range(8)), tuple(range(6))),
}


def observed(stage: Stage, dvl: bool) -> Stage:
    """``stage`` restricted to what the sensors observe: everything with a DVL, without one
    all but :data:`DVL_DOFS`."""
    return stage if dvl else stage.restricted(tuple(d for d in stage.dofs
                                                    if d not in DVL_DOFS))


def prior_values(profile: Profile) -> dict[str, float]:
    """The profile's values of the 18 hydrodynamic parameters (the identification's prior:
    used for parameters a stage does not estimate, never as the starting point of a fit)."""
    mass = tuple(profile.added_mass[:3]) + tuple(
        i + a for i, a in zip(profile.inertia_kg_m2, profile.added_mass[3:], strict=True))
    values = mass + tuple(profile.linear_damping) + tuple(profile.quadratic_damping)
    return dict(zip(HYDRO_NAMES, (float(v) for v in values), strict=True))


def restoring_vector(profile: Profile) -> FloatArray:
    """q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] [N, N·m] of the nominal
    vehicle (r_g = 0 at CG0), so that g(η) = G(φ, θ)·q (:func:`trimd.core.model.restoring_matrix`).
    """
    B = profile.buoyancy_N
    return np.concatenate([[profile.weight_N - B], -B * np.asarray(profile.r_b_m, float)])


@dataclass(frozen=True, eq=False)
class Statics:
    """What the identification holds fixed about mass and restoring forces.

    Attributes
    ----------
    mass_kg : rigid-body mass m [kg] (M_u = m + X_u̇, likewise v, w).
    q_rest : q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] [N, N·m], so that
        g(η) = G(φ, θ)·q (:func:`trimd.core.model.restoring_matrix`).
    source : where they come from, for reports ("profile NAME" or the estimate's file).
    """

    mass_kg: float
    q_rest: FloatArray
    source: str


def statics_of_profile(profile: Profile) -> Statics:
    """The nominal vehicle of ``profile``: its mass and :func:`restoring_vector` (r_g = 0)."""
    return Statics(profile.mass_kg, restoring_vector(profile), f"profile {profile.name}")


def statics_from_estimate(est: StaticEstimate, source: str) -> Statics:
    """A measured static estimate (``trimd solve --json``, ``trimd run``): m = W/g and its
    net quantities q = [W − B, W·r_g − B·r_b] (payload and ballast included)."""
    return Statics(est.weight_N / est.gravity_m_s2, np.asarray(est.q, float).copy(), source)


def lagged_thrust(tau: FloatArray, T_s: float, h: float, lead_s: float | None = None
                  ) -> tuple[FloatArray, FloatArray]:
    """Thrust through a first-order lag; each sampled command acts from ``lead_s`` before
    its sample until ``lead_s`` before the next.

    A sampled thruster output says what the thrusters were commanded at that instant; when
    the command changed is known only to within the thruster record's sample interval
    (which may span several samples of the grid it is held onto), and telemetry streams
    have their own latencies. The default lead h/2 (the change in the middle of the
    interval before the sample that first shows it) makes a uniformly distributed timing
    error zero on average; the fit can estimate the lead (``T_lead``).

    Parameters
    ----------
    tau : commanded τ [N, N·m] at the sample instants, shape (N, 6). The lag starts
        settled on τ[0].
    T_s : lag time constant [s] (0: no lag).
    h : sample interval [s].
    lead_s : how long before its sample a command acts [s], ≥ 0 (whole samples shift the
        record; the last command holds at the end); default h/2.

    Returns
    -------
    start, mid : lagged τ at t_k and at t_k + h/2 (exact), each (N, 6).
    """
    from scipy.signal import lfilter, lfilter_zi  # 1 s to import: only when simulating

    lead = 0.5 * h if lead_s is None else max(lead_s, 0.0)
    shift = min(int(lead / h), len(tau) - 1)
    c = min(lead - shift * h, h)
    tau = np.asarray(tau, float)
    if shift:
        tau = np.concatenate([tau[shift:], np.repeat(tau[-1:], shift, axis=0)])

    def decay(dt: float) -> float:   # after dt ≥ 0 [s]
        dt = max(dt, 0.0)
        return math.exp(-dt / T_s) if T_s > 0 else (1.0 if dt == 0 else 0.0)

    sw, half, rest = decay(h - c), decay(0.5 * h), decay(c)
    after = decay(c - 0.5 * h)
    nxt = np.concatenate([tau[1:], tau[-1:]])
    # τ[k] until t_{k+1} − c, then τ[k + 1]: start[k+1] = a·start[k] + b0·τ[k+1] + b1·τ[k]
    # (a + b0 + b1 = 1: settled on τ[0] at the start)
    b, a = [1.0 - rest, rest * (1.0 - sw)], [1.0, -rest * sw]
    start = lfilter(b, a, tau, axis=0, zi=lfilter_zi(b, a)[:, None] * tau[:1])[0]
    at_switch = tau + sw * (start - tau)
    mid = (tau + half * (start - tau) if c <= 0.5 * h
           else nxt + after * (at_switch - nxt))
    return start, mid


def _derivative(s: list[FloatArray], M: FloatArray, Dl: FloatArray, Dq: FloatArray,
                tau: FloatArray, q_rest: Sequence[float]) -> list[FloatArray]:
    """ẋ of every state component; ``s`` holds 8 arrays (B, K); M, Dl, Dq are (6, B, 1);
    ``tau`` is (K, 6) or, one per parameter vector, (B, K, 6)."""
    u, v, w, p, q, r, phi, th = s
    a1, a2, a3 = M[0] * u, M[1] * v, M[2] * w
    c1, c2, c3 = M[3] * p, M[4] * q, M[5] * r
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(th), np.cos(th)
    # g(η) = G(φ, θ)·q_rest written out (trimd.core.model.restoring_matrix)
    q0, q1, q2, q3 = q_rest
    ctsp, ctcp = ct * sp, ct * cp
    f = (
        tau[..., 0] - (q * a3 - r * a2) + (Dl[0] + Dq[0] * np.abs(u)) * u - st * q0,
        tau[..., 1] - (r * a1 - p * a3) + (Dl[1] + Dq[1] * np.abs(v)) * v + ctsp * q0,
        tau[..., 2] - (p * a2 - q * a1) + (Dl[2] + Dq[2] * np.abs(w)) * w + ctcp * q0,
        tau[..., 3] - (q * c3 - r * c2) - (v * a3 - w * a2)
        + (Dl[3] + Dq[3] * np.abs(p)) * p + ctcp * q2 - ctsp * q3,
        tau[..., 4] - (r * c1 - p * c3) - (w * a1 - u * a3)
        + (Dl[4] + Dq[4] * np.abs(q)) * q - ctcp * q1 - st * q3,
        tau[..., 5] - (p * c2 - q * c1) - (u * a2 - v * a1)
        + (Dl[5] + Dq[5] * np.abs(r)) * r + ctsp * q1 + st * q2,
    )
    tt = st / ct
    return [fi / M[i] for i, fi in enumerate(f)] + [p + (q * sp + r * cp) * tt,
                                                     q * cp - r * sp]


def simulate(M: FloatArray, Dl: FloatArray, Dq: FloatArray, q_rest: FloatArray,
             x0: FloatArray, exo: FloatArray, tau_start: FloatArray, tau_mid: FloatArray,
             states: tuple[int, ...], h: float) -> FloatArray:
    """Integrate K segments for B parameter vectors with RK4 at step ``h`` [s].

    Parameters
    ----------
    M, Dl, Dq : mass entries [kg, kg·m²] and linear and quadratic damping per DOF,
        shape (B, 6).
    q_rest : restoring vector (:func:`restoring_vector`), shape (4,).
    x0 : initial state per parameter vector and segment, shape (B, K, 8).
    exo : measured state at every step, shape (L + 1, K, 8); the components not in
        ``states`` follow it (midpoints interpolated linearly).
    tau_start, tau_mid : lagged thrust at the steps and half steps, shape (L + 1, K, 6),
        or (L + 1, B, K, 6) for one per parameter vector.
    states : simulated state components.
    h : step [s].

    Returns
    -------
    x : simulated ``states`` at steps 1..L, shape (L, B, K, len(states)).
    """
    Mt, Dlt, Dqt = (np.asarray(a, float).T[:, :, None] for a in (M, Dl, Dq))
    q = [float(v) for v in q_rest]
    B, K = x0.shape[:2]
    L = exo.shape[0] - 1
    sim = [i in states for i in range(8)]
    x = [np.array(x0[..., i]) if sim[i] else np.broadcast_to(exo[0, :, i], (B, K))
         for i in range(8)]
    out = np.empty((L, len(states), B, K))

    def at(base: list[FloatArray], d: list[FloatArray] | None, c: float, ex: FloatArray
           ) -> list[FloatArray]:
        return [(base[i] + c * d[i] if d is not None else base[i]) if sim[i]
                else np.broadcast_to(ex[:, i], (B, K)) for i in range(8)]

    # a trial parameter vector whose simulation diverges comes out non-finite, which the
    # fit rejects (trimd.identify.solve): an expected outcome, not a warning for the user
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(L):
            e0, e1 = exo[k], exo[k + 1]
            em = 0.5 * (e0 + e1)
            k1 = _derivative(at(x, None, 0.0, e0), Mt, Dlt, Dqt, tau_start[k], q)
            k2 = _derivative(at(x, k1, 0.5 * h, em), Mt, Dlt, Dqt, tau_mid[k], q)
            k3 = _derivative(at(x, k2, 0.5 * h, em), Mt, Dlt, Dqt, tau_mid[k], q)
            k4 = _derivative(at(x, k3, h, e1), Mt, Dlt, Dqt, tau_start[k + 1], q)
            x = [x[i] + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]) if sim[i]
                 else np.broadcast_to(e1[:, i], (B, K)) for i in range(8)]
            for j, i in enumerate(states):
                out[k, j] = x[i]
    return np.moveaxis(out, 1, -1)
