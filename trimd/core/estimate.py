"""Static estimation of the weight and centre of gravity from steady attitude holds.

At a steady hold the thrusters balance the restoring forces, g(η) = τ (docs/method.md §3).
g(η) = G(φ, θ)·q is linear in the *net* quantities
q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b], so every sample of every hold
stacks into one weighted linear least-squares problem for q. The weight W, the centre of
gravity r_g and m_ext = W/g − m then follow from the profile's buoyancy B and centre of
buoyancy r_b; q itself does not depend on that prior.

Each hold enters at its *mean* attitude (docs/method.md §3: average over the steady window).
Regressing on every sample's measured attitude would put the attitude noise into the
design matrix, and errors in the regressors bias least squares towards zero: at a level
hold the z-moment coefficient sin φ is pure noise, which pulled W·z_g − B·z_b (about
B·|z_b|, hundreds of N·m) towards 0 by enough to bias z_g by 20–30 µm. The mean
attitude's own uncertainty (sample spread over the effective sample count) is carried
into the covariance through ∂(G·q)/∂(φ, θ).

Weighting: the rows of each hold fall into two groups, forces [N] and moments [N·m];
each group gets its own noise variance from the residuals of a first fit, inflated by
the residuals' lag-1 autocorrelation (an effective-sample-size correction). The three
force rows of a hold share one weight on purpose: their coefficients are the body
components of the world vertical, so together they recover W − B exactly even when the
vehicle holds depth but not station and only its vertical thrusters carry the load —
as long as drag is the same in every direction. It is not (heave drag ≫ sway drag), so
by default only level holds, where the vehicle does not drift, contribute force rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from trimd.core.errors import EstimationError
from trimd.core.model import restoring_matrix, restoring_matrix_jacobian, thrust_configuration
from trimd.core.profile import Profile

__all__ = ["HoldSamples", "HoldSummary", "StaticEstimate", "estimate_static", "measurable_dofs"]

FloatArray = NDArray[np.float64]
TAU_NAMES = ("X", "Y", "Z", "K", "M", "N")  # the components of τ (SNAME)
_PARAM_NAMES = ("the net vertical force W − B", "x_g", "y_g", "z_g")
#: Holds whose stacked design has a relative singular value below this cannot separate
#: a parameter (≈ sin 1.1°): an "almost level" hold does not identify z_g.
_MIN_RELATIVE_SINGULAR = 0.02
#: A hold whose mean roll and pitch are below this [rad] (≈ 3°) counts as level.
_LEVEL_RAD = np.radians(3.0)


@dataclass(frozen=True, eq=False)
class HoldSamples:
    """The steady samples of one hold.

    Attributes
    ----------
    t_s : sample times [s], increasing.
    phi, theta : measured roll and pitch [rad].
    tau : generalised thruster force, shape (N, 6) [N, N·m], body FRD.
    label : a name for people ("hold 2", "level").
    """

    t_s: FloatArray
    phi: FloatArray
    theta: FloatArray
    tau: FloatArray
    label: str = ""


@dataclass(frozen=True)
class HoldSummary:
    """What one hold contributed: mean attitude [deg], sample count, window [s]."""

    label: str
    roll_deg: float
    pitch_deg: float
    samples: int
    t_start_s: float
    t_end_s: float


@dataclass(frozen=True, eq=False)
class StaticEstimate:
    """Result of :func:`estimate_static` (SI units, body FRD).

    ``q``/``q_cov`` are the net quantities [W − B, W·r_g − B·r_b] and their covariance;
    ``cov`` is the covariance of [W, x_g, y_g, z_g] (N, m). Standard deviations are 1σ.
    """

    q: FloatArray
    q_cov: FloatArray
    weight_N: float
    buoyancy_N: float
    r_b_m: FloatArray
    r_g_m: FloatArray
    cov: FloatArray
    m_ext_kg: float
    gravity_m_s2: float
    holds: tuple[HoldSummary, ...]
    dofs_used: tuple[str, ...]
    residual_rms: FloatArray = field(repr=False)
    success: bool = True
    message: str = "ok"

    @property
    def weight_std_N(self) -> float:
        return float(np.sqrt(self.cov[0, 0]))

    @property
    def m_ext_std_kg(self) -> float:
        return self.weight_std_N / self.gravity_m_s2

    @property
    def r_g_std_m(self) -> FloatArray:
        return np.sqrt(np.diag(self.cov)[1:])

    @property
    def net_moment_Nm(self) -> FloatArray:
        """W·r_g − B·r_b [N·m]: independent of the profile's centre-of-buoyancy prior."""
        return self.q[1:].copy()

    @property
    def net_moment_std_Nm(self) -> FloatArray:
        return np.sqrt(np.diag(self.q_cov)[1:])


def measurable_dofs(profile: Profile) -> tuple[bool, ...]:
    """Which of X, Y, Z, K, M, N the thrusters can produce (and so measure) on their own.

    A degree of freedom is measurable when its unit vector lies in the range of the
    thrust configuration matrix; a profile without thrusters measures all six.
    """
    if not profile.thrusters:
        return (True,) * 6
    T = thrust_configuration(profile.thrusters)
    P = T @ np.linalg.pinv(T)
    return tuple(bool(np.linalg.norm(P[:, k] - np.eye(6)[k]) < 1e-6) for k in range(6))


def _check_identifiable(holds: Sequence[HoldSamples], rows: NDArray[np.bool_]) -> None:
    """Refuse, naming the missing direction, when the holds cannot determine q."""
    G = np.concatenate([restoring_matrix(np.mean(h.phi), np.mean(h.theta))[rows]
                        for h in holds])
    _, s, vt = np.linalg.svd(G, full_matrices=False)
    if s[-1] >= _MIN_RELATIVE_SINGULAR * s[0]:
        return
    name = _PARAM_NAMES[int(np.argmax(np.abs(vt[-1])))]
    tilts = ", ".join(f"({np.degrees(np.mean(h.phi)):.1f}°, {np.degrees(np.mean(h.theta)):.1f}°)"
                      for h in holds)
    if all(_is_level(h) for h in holds):
        raise EstimationError(
            f"{name} is not identifiable: every hold was level (holds at roll, pitch {tilts});"
            " add a tilted hold, e.g. roll = pitch = 20°")
    used = ", ".join(d for d, r in zip(TAU_NAMES, rows, strict=True) if r)
    raise EstimationError(
        f"{name} is not identifiable from holds at roll, pitch {tilts} with the measured "
        f"rows {used}: at any one attitude the moment about the vertical is invisible, so "
        "at least two holds at different attitudes are needed (e.g. level and roll = pitch "
        "= 20°)")


def _lag1(r: FloatArray) -> float:
    """Pooled lag-1 autocorrelation of the columns of ``r``, clipped to [0, 0.99].

    Pooled (each column weighted by its variance), as the variance it corrects is pooled:
    a plain mean of per-column values lets a column of negligible spread (a thruster row
    stuck in its deadband, say) inflate the variance of the whole group.
    """
    if r.shape[0] < 3:
        return 0.0
    c = r - r.mean(axis=0)
    den = float(np.sum(c * c))
    if den <= 0:
        return 0.0
    return float(np.clip(np.sum(c[1:] * c[:-1]) / den, 0.0, 0.99))


def _mean_attitude_cov(hold: HoldSamples) -> FloatArray:
    """Covariance [rad²] of a hold's mean (φ, θ): spread over the effective sample count."""
    att = np.column_stack([hold.phi, hold.theta])
    c = att - att.mean(axis=0)
    kappa = (1 + (rho := _lag1(c))) / (1 - rho)
    return np.cov(c, rowvar=False) * kappa / len(att)


def _attitude_jacobian(phi: float, theta: float, q: FloatArray) -> FloatArray:
    """∂(G(φ, θ)·q)/∂(φ, θ), shape (6, 2) [N or N·m per rad]."""
    d: FloatArray = np.einsum("ijk,j->ik", restoring_matrix_jacobian(phi, theta), q)
    return d


def _is_level(hold: HoldSamples) -> bool:
    return bool(abs(np.mean(hold.phi)) < _LEVEL_RAD and abs(np.mean(hold.theta)) < _LEVEL_RAD)


def estimate_static(holds: Sequence[HoldSamples], profile: Profile, *,
                    dofs: Sequence[bool] | None = None,
                    level_forces_only: bool = True) -> StaticEstimate:
    """Weighted least squares for the weight and centre of gravity over steady holds.

    Parameters
    ----------
    holds : the steady samples of each hold (at least one tilted hold for z_g).
    profile : gives the nominal mass m, g, the buoyancy B and its centre r_b.
    dofs : which of the six rows of g(η) = τ were measured; default
        :func:`measurable_dofs` of the profile.
    level_forces_only : use the force rows (X, Y, Z) of level holds only, when there is
        one. A vehicle that holds depth but not station drifts at a tilted hold, and the
        drag of that drift (much larger in heave than in sway) biases the tilted force
        rows; the moment rows are barely affected. Level holds do not drift.

    Raises
    ------
    EstimationError : too few samples, non-finite data, or an unidentifiable set-up.

    Examples
    --------
    >>> import numpy as np
    >>> from trimd.core.profile_yaml import load_profile
    >>> from trimd.core.model import restoring_forces
    >>> p = load_profile("sabertooth-dh2")
    >>> W, r_g = (p.mass_kg + 10) * p.gravity_m_s2, np.array([-0.0086, 0.005, 0.0])
    >>> def hold(deg):
    ...     a = np.radians(deg)
    ...     tau = restoring_forces(a, a, W, p.buoyancy_N, r_g, p.r_b_m)
    ...     return HoldSamples(np.arange(3.0), np.full(3, a), np.full(3, a), np.tile(tau, (3, 1)))
    >>> est = estimate_static([hold(0), hold(20)], p)
    >>> round(est.m_ext_kg, 6), [round(float(v), 6) + 0.0 for v in est.r_g_m]
    (10.0, [-0.0086, 0.005, 0.0])
    """
    rows = np.array(measurable_dofs(profile) if dofs is None else dofs, dtype=bool)
    if len(holds) == 0:
        raise EstimationError("no steady hold to estimate from")
    for h in holds:
        if len(h.phi) < 2:
            raise EstimationError(f"hold {h.label!r} has {len(h.phi)} steady samples; "
                                  "at least 2 are needed")
        if not (np.all(np.isfinite(h.phi)) and np.all(np.isfinite(h.theta))
                and np.all(np.isfinite(h.tau))):
            raise EstimationError(f"hold {h.label!r} contains NaN or infinite values")
    _check_identifiable(holds, rows)

    force = rows.copy()
    force[3:] = False
    moment = rows & ~force
    level = [_is_level(h) for h in holds]
    use_force = [lv or not (level_forces_only and any(level)) for lv in level]
    attitude = [(float(np.mean(h.phi)), float(np.mean(h.theta))) for h in holds]
    G = [restoring_matrix(*a) for a in attitude]
    groups = [(k, m) for k, f in enumerate(use_force)
              for m in ((force, moment) if f else (moment,)) if np.any(m)]
    A = [np.tile(G[k][m], (len(holds[k].phi), 1)) for k, m in groups]
    y = [holds[k].tau[:, m].reshape(-1) for k, m in groups]
    q0 = np.linalg.lstsq(np.concatenate(A), np.concatenate(y), rcond=None)[0]

    variances = []
    for (k, m), Ag, yg in zip(groups, A, y, strict=True):
        r = (yg - Ag @ q0).reshape(len(holds[k].phi), int(np.sum(m)))
        kappa = (1 + (rho := _lag1(r))) / (1 - rho)
        variances.append(float(np.mean(r * r)) * kappa)
    scale = max(max(variances), 1e-300)
    weights = [1.0 / np.sqrt(max(v, 1e-12 * scale, 1e-300)) for v in variances]
    Aw = np.concatenate([Ag * w for Ag, w in zip(A, weights, strict=True)])
    yw = np.concatenate([yg * w for yg, w in zip(y, weights, strict=True)])
    q = np.linalg.lstsq(Aw, yw, rcond=None)[0]
    H_inv = np.linalg.inv(Aw.T @ Aw)
    # q moves by −H⁻¹·Σ n·w²·G_mᵀ·D_m·δ for an error δ in a hold's mean attitude
    c = np.zeros((len(holds), 4, 2))
    for (k, m), w in zip(groups, weights, strict=True):
        c[k] += len(holds[k].phi) * w**2 * G[k][m].T @ _attitude_jacobian(*attitude[k], q)[m]
    spread = sum((ck @ _mean_attitude_cov(h) @ ck.T for ck, h in zip(c, holds, strict=True)),
                 np.zeros((4, 4)))
    q_cov = H_inv + H_inv @ spread @ H_inv

    B, r_b = profile.buoyancy_N, np.asarray(profile.r_b_m, float)
    W = float(q[0] + B)
    if W <= 0:
        raise EstimationError(f"estimated weight {W:.1f} N is not positive: check the thrust "
                              "signs and the profile's buoyancy")
    r_g = (q[1:] + B * r_b) / W
    J = np.zeros((4, 4))
    J[0, 0] = 1.0
    J[1:, 0] = -r_g / W
    J[1:, 1:] = np.eye(3) / W
    residuals = np.concatenate([h.tau - Gh @ q for h, Gh in zip(holds, G, strict=True)])
    residual_rms = np.sqrt(np.mean(residuals**2, axis=0))
    summaries = tuple(HoldSummary(h.label, float(np.degrees(a[0])), float(np.degrees(a[1])),
                                  len(h.phi), float(h.t_s[0]), float(h.t_s[-1]))
                      for h, a in zip(holds, attitude, strict=True))
    return StaticEstimate(
        q=q, q_cov=q_cov, weight_N=W, buoyancy_N=B, r_b_m=r_b, r_g_m=r_g,
        cov=J @ q_cov @ J.T, m_ext_kg=W / profile.gravity_m_s2 - profile.mass_kg,
        gravity_m_s2=profile.gravity_m_s2, holds=summaries,
        dofs_used=tuple(d for d, r in zip(TAU_NAMES, rows, strict=True) if r),
        residual_rms=residual_rms)
