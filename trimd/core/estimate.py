"""Static estimation of the weight and centre of gravity from steady attitude holds.

At a steady hold the thrusters balance the restoring forces, g(η) = τ (docs/method.md §3).
g(η) = G(φ, θ)·q is linear in the *net* quantities
q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b], so every sample of every hold
stacks into one weighted linear least-squares problem for q. The weight W, the centre of
gravity r_g and m_ext = W/g − m then follow from the profile's buoyancy B and centre of
buoyancy r_b; q itself does not depend on that prior.

The fit is generalised least squares over *hold means*: each hold enters as its mean τ̄
at its mean attitude, G(φ̄, θ̄)·q = τ̄. Regressing on every sample's measured attitude
instead would put the attitude noise into the regressors and bias the fit towards zero
(at a level hold the z-moment coefficient sin φ is pure noise); repeated samples (thruster
outputs held onto the faster attitude stream) would count as independent.

The uncertainty of a hold's mean comes from its per-sample residuals
e(t) = τ(t) − G(φ(t), θ(t))·q: attitude noise, attitude wander and thruster noise all
enter there, with their real correlation between rows and over time. Their long-run
covariance (:mod:`trimd.core.longrun`: Bartlett kernel, window chosen from the data) is
the covariance of the hold's mean, seconds-long correlation included. Each row is weighted
by its own variance (the thrust curves' share below included), and the covariance of q is
the sandwich H⁻¹·(Σ Aᵀ·W·C·W·A)·H⁻¹, which holds whatever the weights. A hold too short
for its own correlation time is flagged (:attr:`HoldSummary.resolved`): its ± is then
likely too small.

The thrust curve: τ = T·f with f each thruster's thrust read from the profile's curve. A
real thruster gives (1 + ε)·f, ε a gain error with the curve's ``uncertainty_pct`` as its
standard deviation, independent per thruster and per direction of thrust. Every hold
shares it, so it does not average out over time and it correlates the holds' means: the
mean of hold k is off by T·(diag(f̄⁺_k)·ε⁺ + diag(f̄⁻_k)·ε⁻), with f̄±_k the mean positive
and negative parts of each thruster's thrust over the hold (:attr:`HoldSamples.thrust`).
Its covariance between holds k and l, C_kl = T·(diag(f̄⁺_k)·S²·diag(f̄⁺_l) +
diag(f̄⁻_k)·S²·diag(f̄⁻_l))·Tᵀ (S the gain standard deviations) on the rows used, adds
Σ_k Σ_l A_kᵀ·W_k·C_kl·W_l·A_l to the middle of the sandwich. Holds without per-thruster
thrust (τ given directly) carry no such term. The dead-band edges the holds' outputs show
by hunting (:mod:`trimd.core.hunting`) condition the thrust map first
(:func:`with_observed_bands`), and what the samples at a hunting spike delivered,
whatever balanced, is an error of its own per hold in the weights and the sandwich.

The drift: a vehicle that keeps depth but not station (the profile's ``holds_station``
false) drifts at a tilt, and its moment rows carry the Munk moment of that drift on top
of g(η) (:mod:`trimd.core.drift`, from the fitted W − B and the profile's damping and
added mass). It is taken out of each hold's mean moments, and its model error
(:data:`~trimd.core.drift.DRIFT_MODEL_ERROR` of itself, the same for every hold) goes
into the weights and the sandwich like the thrust curves'.

Which rows: the force rows' coefficients are the body components of the world vertical,
so together they would recover W − B even when the vehicle holds depth but not station
and only its vertical thrusters carry the load — if drag were the same in every
direction. It is not (heave drag ≫ sway drag), so by default only level holds, where the
vehicle does not drift, contribute force rows. The identifiability check looks at exactly
the rows the fit uses.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from trimd.core.drift import DRIFT_MODEL_ERROR
from trimd.core.errors import EstimationError
from trimd.core.hunting import (
    EdgeObservation,
    hunting_factors,
    hunting_spikes,
    observed_bands,
    readable_edges,
)
from trimd.core.longrun import MeanCovariance, mean_covariance
from trimd.core.model import informative_rows, restoring_matrix, thrust_configuration
from trimd.core.profile import Profile
from trimd.core.static_estimate import HoldSummary, StaticEstimate, net_estimate
from trimd.core.systematics import (
    attitude_error_factors,
    band_notes,
    drift_moments,
    thrust_map_bias,
    thrust_map_factors,
)
from trimd.core.types import FloatArray

__all__ = ["LEVEL_RAD", "MIN_RELATIVE_SINGULAR", "MOMENT_ROWS", "TAU_NAMES", "HeldOutputs",
           "HoldRecord", "HoldSamples", "HoldSummary", "StaticEstimate", "check_samples",
           "estimate_static", "is_level", "measurable_dofs", "net_estimate"]

TAU_NAMES = ("X", "Y", "Z", "K", "M", "N")  # the components of τ (SNAME)
_PARAM_NAMES = ("the net vertical force W − B", "x_g", "y_g", "z_g")
#: Holds whose stacked design has a relative singular value below this cannot separate
#: a parameter (≈ sin 1.1°): an "almost level" hold does not identify z_g.
MIN_RELATIVE_SINGULAR = 0.02
#: A hold whose mean roll and pitch are below this [rad] (≈ 3°) counts as level.
LEVEL_RAD = float(np.radians(3.0))
#: The moment rows (K, M, N) of τ and G(φ, θ).
MOMENT_ROWS = np.array([False, False, False, True, True, True])


@dataclass(frozen=True, eq=False)
class HeldOutputs:
    """The thruster outputs behind a hold's thrust, one row per sample: each thruster's
    PWM [µs] (shape (N, n), the profile's thruster order) and the battery voltage [V]
    (shape (N,)) held onto the sample, as its thrust was read through the curves."""

    pwm_us: FloatArray
    voltage_V: FloatArray

    def take(self, index: NDArray[Any]) -> HeldOutputs:
        """The rows at ``index`` (a boolean mask or an integer index)."""
        return HeldOutputs(self.pwm_us[index], self.voltage_V[index])


@dataclass(frozen=True, eq=False)
class HoldSamples:
    """The steady samples of one hold.

    Attributes
    ----------
    t_s : sample times [s], increasing.
    phi, theta : measured roll and pitch [rad].
    tau : generalised thruster force, shape (N, 6) [N, N·m], body FRD.
    label : a name for people ("hold 2", "level").
    thrust : the thrust of each thruster along its positive direction, shape (N, n) in the
        profile's thruster order [N], τ = T·f (:func:`trimd.core.model.thrusts_from_pwm`);
        None when τ did not come from the profile's thrust curves (then the curves'
        uncertainty does not enter the ±).
    outputs : the outputs that thrust was read from; None where they were not kept (a
        hold found in a log). A calibration fits the thrust map to them
        (:mod:`trimd.core.thrust_fit`), and applies what it learnt through them.
    """

    t_s: FloatArray
    phi: FloatArray
    theta: FloatArray
    tau: FloatArray
    label: str = ""
    thrust: FloatArray | None = None
    outputs: HeldOutputs | None = None

    def take(self, index: FloatArray, label: str | None = None) -> HoldSamples:
        """The samples at ``index`` (an integer index or a boolean mask), named ``label``
        (this hold's label when None)."""
        out = self.outputs
        return HoldSamples(self.t_s[index], self.phi[index], self.theta[index],
                           self.tau[index], self.label if label is None else label,
                           None if self.thrust is None else self.thrust[index],
                           None if out is None else out.take(index))


@dataclass
class HoldRecord:
    """A hold's samples while they are collected (growing lists), frozen into
    :class:`HoldSamples` at the end: the set-point roll and pitch [rad], and per sample its
    time [s], roll and pitch [rad], τ [N, N·m], each thruster's thrust [N] and the outputs
    it was read from (PWM [µs], battery voltage [V])."""

    phi: float
    theta: float
    t: list[float] = field(default_factory=list)
    att: list[tuple[float, float]] = field(default_factory=list)
    tau: list[FloatArray] = field(default_factory=list)
    thrust: list[FloatArray] = field(default_factory=list)
    pwm: list[tuple[float, ...]] = field(default_factory=list)
    volts: list[float] = field(default_factory=list)

    def samples(self, label: str) -> HoldSamples:
        a = np.array(self.att, dtype=float).reshape(-1, 2)
        n = len(self.t)
        return HoldSamples(np.array(self.t), a[:, 0], a[:, 1],
                           np.array(self.tau).reshape(-1, 6), label,
                           np.array(self.thrust).reshape(n, -1),
                           HeldOutputs(np.array(self.pwm, float).reshape(n, -1),
                                       np.array(self.volts, float)))


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


def _check_identifiable(holds: Sequence[HoldSamples], G: Sequence[FloatArray],
                        rows: Sequence[NDArray[np.bool_]]) -> None:
    """Refuse, naming the missing direction, when the rows the fit uses cannot determine q."""
    A = np.concatenate([Gk[r] for Gk, r in zip(G, rows, strict=True)])
    _, s, vt = np.linalg.svd(A, full_matrices=False)
    if len(s) == 4 and s[-1] >= MIN_RELATIVE_SINGULAR * s[0]:
        return
    name = _PARAM_NAMES[int(np.argmax(np.abs(vt[-1])))] if len(s) == 4 else _PARAM_NAMES[3]
    tilts = ", ".join(f"({np.degrees(np.mean(h.phi)):.1f}°, {np.degrees(np.mean(h.theta)):.1f}°)"
                      for h in holds)
    if all(is_level(h) for h in holds):
        raise EstimationError(
            f"{name} is not identifiable: every hold was level (holds at roll, pitch {tilts});"
            " add a tilted hold, e.g. roll = pitch = 20°")
    used = "; ".join(f"{h.label or k + 1}: " + ",".join(d for d, u in zip(TAU_NAMES, r,
                                                                          strict=True) if u)
                     for k, (h, r) in enumerate(zip(holds, rows, strict=True)))
    raise EstimationError(
        f"{name} is not identifiable from holds at roll, pitch {tilts} with the rows used "
        f"({used}): force rows count at level holds only, and at any one attitude the "
        "moment about the vertical is invisible, so at least two holds at different "
        "attitudes with the Z row measured at a level one are needed (e.g. level and "
        "roll = pitch = 20°)")


def check_samples(hold: HoldSamples, what: str = "hold") -> None:
    """EstimationError, naming the ``what`` (hold, segment), for fewer than 2 samples or
    non-finite data."""
    if len(hold.phi) < 2:
        raise EstimationError(f"{what} {hold.label!r} has {len(hold.phi)} steady samples; "
                              "at least 2 are needed")
    if not (np.all(np.isfinite(hold.phi)) and np.all(np.isfinite(hold.theta))
            and np.all(np.isfinite(hold.tau))):
        raise EstimationError(f"{what} {hold.label!r} contains NaN or infinite values")


def is_level(hold: HoldSamples) -> bool:
    """Are the hold's mean roll and pitch both within 3° of level?"""
    return bool(abs(np.mean(hold.phi)) < LEVEL_RAD and abs(np.mean(hold.theta)) < LEVEL_RAD)


def _residual_means(holds: Sequence[HoldSamples], rows: Sequence[NDArray[np.bool_]],
                    q: FloatArray) -> list[MeanCovariance]:
    """Per hold, the mean of τ − G(φ, θ)·q over its samples (the rows used) with its
    long-run covariance: attitude noise, wander and thruster noise all enter through the
    per-sample residual, correlated as they really are."""
    out = []
    for h, r in zip(holds, rows, strict=True):
        e = h.tau[:, r] - np.einsum("nij,j->ni", restoring_matrix(h.phi, h.theta)[:, r], q)
        out.append(mean_covariance(e))
    return out


def _group_scales(holds: Sequence[HoldSamples],
                  used: Sequence[NDArray[np.bool_]]) -> list[FloatArray]:
    """Per hold, 1/spread of each used row, pooled over all force rows and over all moment
    rows of all holds [1/N, 1/(N·m)]."""
    dev: dict[bool, list[FloatArray]] = {False: [], True: []}
    for h, r in zip(holds, used, strict=True):
        d = h.tau[:, r] - h.tau[:, r].mean(axis=0)
        for column, is_moment in zip(d.T, np.flatnonzero(r) >= 3, strict=True):
            dev[bool(is_moment)].append(column)
    rms = {m: max(float(np.sqrt(np.mean(np.concatenate(v) ** 2))) if v else 1.0, 1e-12)
           for m, v in dev.items()}
    return [np.where(np.flatnonzero(r) >= 3, 1 / rms[True], 1 / rms[False]) for r in used]


def _weighted_fit(A: Sequence[FloatArray], tau: Sequence[FloatArray],
                  weights: Sequence[FloatArray]) -> FloatArray:
    """q minimising Σ_k ‖w_k·(τ̄_k − A_k·q)‖²."""
    Aw = np.concatenate([Ak * w[:, None] for Ak, w in zip(A, weights, strict=True)])
    yw = np.concatenate([t * w for t, w in zip(tau, weights, strict=True)])
    q: FloatArray = np.linalg.lstsq(Aw, yw, rcond=None)[0]
    return q


def spikes_of(hold: HoldSamples, profile: Profile) -> list[EdgeObservation]:
    """The hunting spikes of ``hold``'s outputs (:func:`~trimd.core.hunting.
    hunting_spikes`); none for a hold without outputs or per-thruster thrust."""
    if hold.outputs is None or hold.thrust is None:
        return []
    return hunting_spikes(hold.outputs.pwm_us, float(np.mean(hold.outputs.voltage_V)), profile)


def with_observed_bands(spikes: Sequence[EdgeObservation], profile: Profile) -> Profile:
    """``profile`` with its thrust map (its calibration, else its prior) conditioned on
    the dead-band edges that the hunting ``spikes`` show (:func:`~trimd.core.hunting.
    readable_edges`); ``profile`` itself when they show none it did not know."""
    known = observed_bands(profile.thrust_map, readable_edges(spikes, profile), profile)
    return profile if known is profile.thrust_map else replace(profile, thrust_map=known)


def estimate_static(holds: Sequence[HoldSamples], profile: Profile, *,
                    dofs: Sequence[bool] | None = None) -> StaticEstimate:
    """Weighted least squares for the weight and centre of gravity over steady holds.

    Parameters
    ----------
    holds : the steady samples of each hold (at least one tilted hold for z_g).
    profile : gives the nominal mass m, g, the buoyancy B and its centre r_b.
    dofs : which of the six rows of g(η) = τ were measured; default
        :func:`measurable_dofs` of the profile.

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
        check_samples(h)
    seen = [spikes_of(h, profile) for h in holds]
    profile = with_observed_bands([o for k in seen for o in k], profile)
    level = [is_level(h) for h in holds]
    # a vehicle that holds depth, not station, drifts at a tilted hold: the drag of the
    # drift (heave drag ≫ sway drag) biases the tilted force rows; level holds do not drift
    use_force = [lv or profile.holds_station or not any(level) for lv in level]
    attitude = [(float(np.mean(h.phi)), float(np.mean(h.theta))) for h in holds]
    # rows that carry no information at a hold's attitude (X, Y, N at level) are left out
    used = [rows & (MOMENT_ROWS | f) & informative_rows(*a)
            for a, f in zip(attitude, use_force, strict=True)]
    G = [restoring_matrix(*a) for a in attitude]
    _check_identifiable(holds, G, used)
    A = [Gk[r] for Gk, r in zip(G, used, strict=True)]
    tau = [h.tau[:, r].mean(axis=0) for h, r in zip(holds, used, strict=True)]
    # a first fit with one scale for the forces and one for the moments (the pooled
    # spread: a single row's spread can be zero, a thruster idle in its dead band), then
    # generalised least squares over the hold means weighted by their long-run variances,
    # twice (the residuals depend on q)
    # each weight is 1/σ of its row's mean, thrust-curve gain errors included: a row
    # whose noise is nil but whose thrust is uncertain is not exact
    gains = thrust_map_factors(holds, used, profile)
    hunting = [hunting_factors(k, r, profile) for k, r in zip(seen, used, strict=True)]
    if profile.thrust_map is not None:  # the calibration's mean correction of the map
        tau = [t + b for t, b in zip(tau, thrust_map_bias(holds, used, profile), strict=True)]
    scale = _group_scales(holds, used)
    q = _weighted_fit(A, tau, scale)
    for _ in range(2):
        drift = drift_moments(attitude, used, profile, float(q[0]))
        tilt = attitude_error_factors(attitude, used, profile, q)
        means = _residual_means(holds, used, q)
        var = [np.diag(m.interval_cov) + (g**2).sum(axis=1) + (u**2).sum(axis=1)
               + (DRIFT_MODEL_ERROR * d)**2 + (e**2).sum(axis=1)
               for m, g, u, d, e in zip(means, gains, hunting, drift, tilt, strict=True)]
        floor = max(1e-12 * max(float(v.max()) for v in var),
                    min(float(v.min()) for v in var), 1e-300)
        # 1/σ weights scaled into (0, 1], so that the sandwich below cannot overflow
        weights = [np.sqrt(floor / np.maximum(v, floor)) for v in var]
        q = _weighted_fit(A, [t - d for t, d in zip(tau, drift, strict=True)], weights)
    means = _residual_means(holds, used, q)
    # sandwich covariance: the weights need not be exact for it to hold
    H_inv = np.linalg.inv(sum((Ak.T * w**2) @ Ak for Ak, w in zip(A, weights, strict=True)))
    meat = sum(((Ak.T * w**2) @ m.interval_cov @ (Ak * w[:, None]**2) for Ak, w, m in
                zip(A, weights, means, strict=True)), np.zeros((4, 4)))
    q_cov_noise = H_inv @ meat @ H_inv
    # the thrust map's errors (curve gains, dead-band edges), shared by all holds:
    # U = Σ_k A_kᵀ·W_k·F_k with F_k the hold's factors, and the meat gains U·Uᵀ
    n = len(profile.thrusters)
    U = sum(((Ak.T * w**2) @ g for Ak, w, g in zip(A, weights, gains, strict=True)),
            np.zeros((4, 4 * n)))
    meat = meat + U @ U.T
    band_meat = U[:, 2 * n:] @ U[:, 2 * n:].T
    # what hunting samples delivered (whatever balanced), one value per hold
    for Ak, w, u in zip(A, weights, hunting, strict=True):
        U = (Ak.T * w**2) @ u
        meat, band_meat = meat + U @ U.T, band_meat + U @ U.T
    q_cov_band = H_inv @ band_meat @ H_inv
    # the drift model's error, one for all holds
    U_drift = sum(((Ak.T * w**2) @ (DRIFT_MODEL_ERROR * d) for Ak, w, d in
                   zip(A, weights, drift, strict=True)), np.zeros(4))
    meat = meat + np.outer(U_drift, U_drift)
    # the attitude reference's slow error, one per hold
    for Ak, w, e in zip(A, weights, tilt, strict=True):
        U = (Ak.T * w**2) @ e
        meat = meat + U @ U.T
    q_cov = H_inv @ meat @ H_inv

    residuals = np.concatenate([h.tau - Gh @ q for h, Gh in zip(holds, G, strict=True)])
    summaries = tuple(HoldSummary(h.label, float(np.degrees(a[0])), float(np.degrees(a[1])),
                                  len(h.phi), float(h.t_s[0]), float(h.t_s[-1]),
                                  m.effective_samples, m.resolved)
                      for h, a, m in zip(holds, attitude, means, strict=True))
    return net_estimate(
        q, q_cov, profile, holds=summaries,
        dofs_used=tuple(d for d, r in zip(TAU_NAMES, rows, strict=True) if r),
        residual_rms=np.sqrt(np.mean(residuals**2, axis=0)), q_cov_noise=q_cov_noise,
        q_cov_band=q_cov_band,
        notes=band_notes(holds, used, gains, means, q, q_cov, q_cov_band))
