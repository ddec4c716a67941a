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
command. Its state is one (8, B, K) array and each term of the equations one operation on
all six DOFs (the per-step cost is Python's, not the arithmetic's, at these sizes); the
measured components are overwritten with the measurements at every RK4 stage.
"""

from __future__ import annotations

import math
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


#: The velocity components as the first and the second factors of the cross products
#: (v × (M₁·v) in surge, sway and heave, ω × (M₂·ω) in roll, pitch and yaw).
_P1 = np.array([1, 2, 0, 4, 5, 3])
_P2 = np.array([2, 0, 1, 5, 3, 4])


#: What is known in advance of the measured angles at one step: sin φ and cos φ when φ is
#: measured and θ is not, the factors of :func:`_restoring_rows` when both are (else
#: ``None``: computed from the state).
_Angles = tuple[tuple[FloatArray, FloatArray] | None, tuple[FloatArray, FloatArray] | None]


def _restoring_rows(sp: FloatArray, cp: FloatArray, st: FloatArray, ct: FloatArray
                    ) -> tuple[FloatArray, FloatArray]:
    """The angle factors of g(η) = G(φ, θ)·q_rest (:func:`trimd.core.model.restoring_matrix`)
    from sin φ, cos φ, sin θ, cos θ (one shape): the first term of every DOF's and the
    second of roll, pitch and yaw's, stacked on a new first axis (6 and 3 long; np.array
    rather than np.stack, which costs three times as much at these sizes)."""
    ctsp, ctcp = ct * sp, ct * cp
    return np.array([st, ctsp, ctcp, ctcp, ctcp, ctsp]), np.array([ctsp, st, st])


def _derivative(s: FloatArray, M: FloatArray, Dl: FloatArray, Dq: FloatArray,
                tau: FloatArray, g: tuple[FloatArray, FloatArray], angles: _Angles
                ) -> FloatArray:
    """ẋ (8, B, K) at the state ``s`` (8, B, K); M, Dl, Dq are (6, B, 1), ``tau`` (6, 1, K)
    or (6, B, K); ``g`` the entries of the restoring vector that multiply the angle factors
    of :func:`_restoring_rows` (signed), (6, 1, 1) and (3, 1, 1); ``angles`` what is
    known of the measured angles (:data:`_Angles`). The rows of measured components are
    not used (the rate of an angle ``angles`` knows is zero).

    Per DOF the operations of its equation written out, in their order (x − a·b as
    x + a·(−b), which rounds alike): τ − C(ν)·ν with the Kirchhoff form
    C(ν)·ν = [ω × (M₁·v); ω × (M₂·ω) + v × (M₁·v)], plus the damping, minus g(η)."""
    nu = s[:6]
    m = M * nu                                             # M₁·v, M₂·ω
    n1, n2, m1, m2 = nu[_P1], nu[_P2], m[_P1], m[_P2]
    cross = n1 * m2 - n2 * m1                              # v × (M₁·v), ω × (M₂·ω)
    f = np.empty_like(cross)
    f[:3] = tau[:3] - (n1[3:] * m2[:3] - n2[3:] * m1[:3])  # ω × (M₁·v)
    f[3:] = tau[3:] - cross[3:] - cross[:3]
    f += (Dl + Dq * np.abs(nu)) * nu
    out = np.empty((8, *f.shape[1:]))
    roll, rows = angles
    if rows is None:
        sp, cp = (np.sin(s[6]), np.cos(s[6])) if roll is None else roll
        st, ct = np.sin(s[7]), np.cos(s[7])
        rows = _restoring_rows(sp, cp, st, ct)
        p, q, r = nu[3:]
        out[6] = p + (q * sp + r * cp) * (st / ct) if roll is None else 0.0
        out[7] = q * cp - r * sp
    else:
        out[6:] = 0.0
    f += rows[0] * g[0]
    f[3:] += rows[1] * g[1]
    np.divide(f, M, out=out[:6])
    return out


def _measured_angles(ex: FloatArray, measured: FloatArray) -> list[_Angles]:
    """:data:`_Angles` of every step from the measured components ``ex`` (steps, ·, 1, K)
    (``measured``: which, ascending; φ and θ come last)."""
    n = len(ex)
    if 6 in measured and 7 in measured:
        a, b = ex[:, -2], ex[:, -1]
        first, second = _restoring_rows(np.sin(a), np.cos(a), np.sin(b), np.cos(b))
        return [(None, rows) for rows in zip(np.moveaxis(first, 0, 1),
                                             np.moveaxis(second, 0, 1), strict=True)]
    if 6 in measured:
        a = ex[:, -1]
        return [(roll, None) for roll in zip(np.sin(a), np.cos(a), strict=True)]
    return [(None, None)] * n


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
    q0, q1, q2, q3 = (float(v) for v in q_rest)
    g = (np.array([-q0, q0, q0, q2, -q1, q1])[:, None, None],
         np.array([-q3, -q3, q2])[:, None, None])
    L = exo.shape[0] - 1
    sim = np.array(states, int)
    # the whole state is one (8, B, K) array; every step overwrites the measured
    # components (those not simulated) with the measurements, (·, 1, K) per step and half
    # step; the thrust per step (6, 1 or B, K)
    measured = np.array([i for i in range(8) if i not in states], int)
    e0 = np.ascontiguousarray(np.moveaxis(exo[:, :, measured], -1, 1)[:, :, None])
    em = 0.5 * (e0[:-1] + e0[1:])
    t0, tm = (np.ascontiguousarray(np.moveaxis(t, -1, 1) if t.ndim == 4
                                   else np.moveaxis(t, -1, 1)[:, :, None])
              for t in (tau_start, tau_mid))
    a0, am = _measured_angles(e0, measured), _measured_angles(em, measured)
    x = np.empty((8, *x0.shape[:2]))
    x[sim] = np.moveaxis(x0, -1, 0)[sim]
    out = np.empty((L, len(sim), *x0.shape[:2]))
    c, h6 = 0.5 * h, h / 6.0

    def at(y: FloatArray, ex: FloatArray) -> FloatArray:
        if measured.size:
            y[measured] = ex
        return y

    # a trial parameter vector whose simulation diverges comes out non-finite, which the
    # fit rejects (trimd.identify.solve): an expected outcome, not a warning for the user
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(L):
            at(x, e0[k])
            k1 = _derivative(x, Mt, Dlt, Dqt, t0[k], g, a0[k])
            k2 = _derivative(at(x + c * k1, em[k]), Mt, Dlt, Dqt, tm[k], g, am[k])
            k3 = _derivative(at(x + c * k2, em[k]), Mt, Dlt, Dqt, tm[k], g, am[k])
            k4 = _derivative(at(x + h * k3, e0[k + 1]), Mt, Dlt, Dqt, t0[k + 1], g, a0[k + 1])
            x = x + h6 * (k1 + 2.0 * (k2 + k3) + k4)
            np.take(x, sim, axis=0, out=out[k])
    return np.moveaxis(out, 1, -1)
