"""The thrust map learns: known ballast changes as calibration experiments
(docs/method.md §7).

Two steady holds at the same (level) attitude with a known ballast change between them
— a trim's level hold and the verify hold after ``ballast apply``, two verify holds
around a correction, or a deliberate calibration (level hold, a known weight hung at a
known slot, level hold) — are an experiment with a known answer. Between them the net
quantities q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b, W·z_g − B·z_b] (body FRD, N and
N·m) change by Δq, what the pieces add: Σ count·w·[1, r_slot], w a piece's net downward
force in water (the profile's inventory) and r_slot its slot's position (body FRD, m).

The thrust map's systematic errors are those :mod:`trimd.core.systematics` models: per
thruster a relative gain error forward and reverse and the offsets of its ESC's dead-band
edges, the vector ε; in units of its prior 1σ, z = ε/σ ~ N(0, I). A hold k's mean τ as
the profile's map reads it (τ = T·f̄, Fossen's thrust configuration T) is off the truth
by F_k·z, F_k the hold's factors (:func:`~trimd.core.systematics.exposure_factors`), and
the truth balances g(η): τ̄_k + F_k·z = G(φ_k, θ_k)·q_k. The difference of the two holds
is linear in z:

    y = G₂·(q₁ + Δq) − G₁·q₁ − (τ̄₂ − τ̄₁) = (F₂ − F₁)·z + v,

on the rows a level hold measures (Z, K, M). q₁ (the trim's estimate, or the profile's
nominal vehicle) enters only through G₂ − G₁, nil when both holds are at the same
attitude. v carries each hold's noise and wander (the long-run covariance of its mean),
the attitude reference's slow error of each hold, what each hold's hunting samples
delivered (:func:`~trimd.core.hunting.hunting_factors`), Δq's uncertainty from the
inventory's ``uncertainty_pct`` and q₁'s through G₂ − G₁: its covariance R. The dead-band
edges the holds show by hunting condition the prior before any experiment is fitted
(:func:`edges_of`, :func:`~trimd.core.hunting.observed_bands`).

That linear model is how an estimate's ± carries the thrust map; the calibration fits z
nonlinearly (:mod:`trimd.core.thrust_fit`): each experiment's change of τ predicted from
its holds' thruster outputs read through the curves with the errors z (a band's factor
above is a magnitude, right for a ± but not for the sign a shift has near the band);
experiments whose holds kept no outputs predict linearly. Rows the data leave
undetermined keep the prior.

Before an experiment is learnt its innovation (target − prediction at the posterior
mean) is compared with its predicted covariance J·P·Jᵀ + R, twice: its χ² with one
degree of freedom per row, and its component along the change the recorded ballast makes
(how many times that change the thrusters saw; one degree of freedom). An experiment
that disagrees with what the earlier ones taught (a piece heavier than its inventory
entry, a wrong slot) is rejected and says which, by how much and what to check.
Experiments are combined in order, the rejected ones left out. A float right after a
level hold (:mod:`trimd.core.float_reference`) is checked and learnt alike; it changes no
ballast, so its χ² alone checks it.

A later estimate uses the posterior through the profile's ``thrust_map``
(:class:`ThrustMapPosterior`): each hold's mean τ is read again through the curves with
the errors μ (F·μ for a hold without outputs) and its factors become F·L, L·Lᵀ = P
(:func:`~trimd.core.systematics.thrust_map_factors`, ``thrust_map_bias``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trimd.core.errors import EstimationError
from trimd.core.estimate import LEVEL_RAD, HoldSamples, measurable_dofs
from trimd.core.float_reference import FloatReference, reference_model
from trimd.core.hunting import EdgeObservation, observed_bands, readable_edges
from trimd.core.longrun import mean_covariance
from trimd.core.map_posterior import ThrustMapPosterior, posterior, prior
from trimd.core.model import restoring_matrix, thrust_configuration
from trimd.core.output_hist import OutputHistogram, output_histogram, spikes_seen
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.systematics import exposure_factors, hold_error_cov, thrust_exposure
from trimd.core.thrust_fit import ChangeModel, Gaussian, fit, innovation
from trimd.core.types import FloatArray

__all__ = ["REJECT_P", "Calibration", "CalibrationHold", "Experiment", "FloatReference",
           "Outcome", "PieceChange", "ThrustMapPosterior", "ballast_change", "calibrate",
           "calibration_hold", "change_model", "edges_of", "experiment_rows", "installed_change",
           "posterior", "prior", "update"]

#: The rows of τ a level hold measures: Z, K, M.
ROWS = np.array([False, False, True, True, True, False])
_ROW_NAMES = {2: "Z (W − B)", 3: "K (W·y_g − B·y_b)", 4: "M (W·x_g − B·x_b)"}
#: An experiment whose innovation has a χ² tail probability below this is rejected.
REJECT_P = 1e-3
#: The hunting spikes of an experiment's holds (before, after).
Hunting = tuple[tuple[EdgeObservation, ...], tuple[EdgeObservation, ...]]


@dataclass(frozen=True, eq=False)
class CalibrationHold:
    """A steady hold as a calibration experiment needs it.

    Attributes
    ----------
    label : for people ("trim 3, hold 1").
    phi_rad, theta_rad : mean roll and pitch [rad].
    tau : mean τ by the profile's thrust map, shape (6,) [N, N·m], body FRD.
    tau_cov : covariance of that mean from noise and wander (long-run, of the residual
        τ − G(φ, θ)·q), shape (6, 6) [N², N²·m², N²·m].
    exposure : :func:`~trimd.core.systematics.thrust_exposure`, shape (4·n,) [N].
    outputs : the hold's thruster outputs (:mod:`trimd.core.output_hist`); None for a hold
        that kept none (recorded before holds kept them, or found in a log).
    """

    label: str
    phi_rad: float
    theta_rad: float
    tau: FloatArray
    tau_cov: FloatArray
    exposure: FloatArray
    outputs: OutputHistogram | None = None


def calibration_hold(hold: HoldSamples, profile: Profile, q: FloatArray) -> CalibrationHold:
    """Summarise ``hold`` (its per-thruster thrust needed); ``q`` [N, N·m] the vehicle's
    net quantities then (an estimate), for the residual whose covariance is taken."""
    if hold.thrust is None:
        raise EstimationError(f"hold {hold.label!r}: no per-thruster thrust, no calibration")
    e = hold.tau - np.einsum("nij,j->ni", restoring_matrix(hold.phi, hold.theta), q)
    return CalibrationHold(hold.label, float(np.mean(hold.phi)), float(np.mean(hold.theta)),
                           hold.tau.mean(axis=0), mean_covariance(e).interval_cov,
                           thrust_exposure(hold, profile),
                           None if hold.outputs is None else output_histogram(hold.outputs))


@dataclass(frozen=True)
class PieceChange:
    """``count`` pieces of inventory kind ``piece`` added to ``slot`` (negative: removed).

    A known weight that is no inventory piece (``trimd calibrate --mass``) gives its own
    ``net_down_N``, its net downward force in water [N] (``piece`` then only names it), and
    ``uncertainty_pct``, its 1σ [%]."""

    slot: str
    piece: str
    count: int
    net_down_N: float | None = None
    uncertainty_pct: float = 1.0


@dataclass(frozen=True, eq=False)
class Experiment:
    """Two holds at one attitude around a known ballast change.

    Attributes
    ----------
    label : for people ("trim 3 → verify 5").
    before, after : the holds.
    change : the ballast fitted between them.
    q_before, q_before_cov : the vehicle's net quantities at ``before`` and their
        covariance [N, N·m] (only their part through G₂ − G₁ counts).
    """

    label: str
    before: CalibrationHold
    after: CalibrationHold
    change: tuple[PieceChange, ...]
    q_before: FloatArray
    q_before_cov: FloatArray


def installed_change(before: Sequence[InstalledPiece], now: Sequence[InstalledPiece]
                     ) -> tuple[PieceChange, ...]:
    """What was fitted between the ballast configurations ``before`` and ``now``: each
    slot and piece whose count changed, by how much (sorted by slot, then piece).

    Examples
    --------
    >>> [(c.slot, c.piece, c.count) for c in installed_change(
    ...     [InstalledPiece("B", "lead", 2), InstalledPiece("A", "foam", 1)],
    ...     [InstalledPiece("B", "lead", 1), InstalledPiece("A", "foam", 1),
    ...      InstalledPiece("C", "lead", 3)])]
    [('B', 'lead', -1), ('C', 'lead', 3)]
    """
    counts: dict[tuple[str, str], int] = {}
    for sign, pieces in ((-1, before), (1, now)):
        for p in pieces:
            counts[(p.slot, p.piece)] = counts.get((p.slot, p.piece), 0) + sign * p.count
    return tuple(PieceChange(s, p, n) for (s, p), n in sorted(counts.items()) if n)


def ballast_change(profile: Profile, change: Sequence[PieceChange]
                   ) -> tuple[FloatArray, FloatArray]:
    """Δq of ``change`` [N, N·m] and its covariance from each inventory kind's
    ``uncertainty_pct`` (one error per kind, shared by its pieces; one per known weight)."""
    dq, cov = np.zeros(4), np.zeros((4, 4))
    kinds: dict[str, list[PieceChange]] = {}
    for c in change:
        key = f"known {c.piece}" if c.net_down_N is not None else profile.piece(c.piece).name
        kinds.setdefault(key, []).append(c)
    for group in kinds.values():
        first = group[0]
        if first.net_down_N is None:
            piece = profile.piece(first.piece)
            w = piece.net_down_N(profile.water_density_kg_m3, profile.gravity_m_s2)
            pct = piece.net_uncertainty_pct
        else:
            w, pct = first.net_down_N, first.uncertainty_pct
        J = sum((c.count * np.r_[1.0, profile.slot(c.slot).position_m] for c in group),
                np.zeros(4))
        dq += w * J
        cov += np.outer(J, J) * (w * pct / 100) ** 2
    return dq, cov


def experiment_rows(exp: Experiment, profile: Profile, hunting: Hunting = ((), ())
                    ) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """The linear model y = H·z + v of ``exp`` (module docstring): y [N, N·m], H (rows,
    4·n), the covariance R of v (what the samples of the holds' ``hunting`` spikes,
    before and after, delivered included), and which rows of τ they are.
    EstimationError when a hold is not level or the thrusters in the profile do not match
    the holds'."""
    b, a = exp.before, exp.after
    n = len(profile.thrusters)
    for h in (b, a):
        if max(abs(h.phi_rad), abs(h.theta_rad)) >= LEVEL_RAD:
            raise EstimationError(f"experiment {exp.label!r}: hold {h.label!r} is not level "
                                  "(a calibration compares level holds)")
        if h.exposure.shape != (4 * n,):
            raise EstimationError(f"experiment {exp.label!r}: hold {h.label!r} has "
                                  f"{len(h.exposure) // 4} thrusters, the profile {n}")
    r = ROWS & np.array(measurable_dofs(profile), bool)
    dq, dq_cov = ballast_change(profile, exp.change)
    q1, q2 = exp.q_before, exp.q_before + dq
    G1 = restoring_matrix(b.phi_rad, b.theta_rad)[r]
    G2 = restoring_matrix(a.phi_rad, a.theta_rad)[r]
    y = G2 @ q2 - G1 @ q1 - (a.tau - b.tau)[r]
    H = exposure_factors(a.exposure, r, profile) - exposure_factors(b.exposure, r, profile)
    D = G2 - G1
    R = (b.tau_cov[np.ix_(r, r)] + a.tau_cov[np.ix_(r, r)] + G2 @ dq_cov @ G2.T
         + D @ exp.q_before_cov @ D.T)
    for h, q, spikes in ((b, q1, hunting[0]), (a, q2, hunting[1])):
        R = R + hold_error_cov(h.phi_rad, h.theta_rad, r, profile, q, spikes)
    return y, H, R, r


@dataclass(frozen=True)
class Outcome:
    """What became of one experiment.

    Attributes
    ----------
    label : the experiment's.
    accepted : learnt (True) or rejected as inconsistent (False).
    chi2 : innovation χ² against its predicted covariance; dof its rows.
    sigma : the check's tail probability (:func:`_checked`: the χ² and the scale of the
        recorded change, each at half) as a two-sided normal deviation [σ].
    message : for people: learnt, or why not and what to check.
    """

    label: str
    accepted: bool
    chi2: float
    dof: int
    sigma: float
    message: str


def _what_to_check(profile: Profile, exp: Experiment | FloatReference) -> str:
    if isinstance(exp, FloatReference):
        return ("check that nothing moved or was hung between the hold and the float, that "
                "nothing touched the vehicle while it floated, and the stiffness it was "
                "given (a trim's z_g)")
    change = exp.change
    pieces = sorted({profile.piece(c.piece).name for c in change if c.net_down_N is None})
    known = sorted({c.piece for c in change if c.net_down_N is not None})
    slots = sorted({profile.slot(c.slot).name for c in change})
    what = ([f"the inventory entr{'ies' if len(pieces) > 1 else 'y'} of {', '.join(pieces)} "
             "(mass_kg, volume_m3)"] if pieces else []) + [
        f"the known weight {k} (its weight in water)" for k in known]
    return (f"check {', '.join(what)}, the slot{'s' if len(slots) > 1 else ''} "
            f"{', '.join(slots)} (position_m) and that the pieces went where recorded")


def change_model(exp: Experiment | FloatReference, profile: Profile) -> ChangeModel:
    """``exp`` as the fit sees it (:mod:`trimd.core.thrust_fit`)."""
    if isinstance(exp, FloatReference):
        return reference_model(exp, profile)
    b, a = exp.before.outputs, exp.after.outputs
    hunting = (() if b is None else tuple(spikes_seen(b, profile)),
               () if a is None else tuple(spikes_seen(a, profile)))
    y, H, R, rows = experiment_rows(exp, profile, hunting)
    measured = (exp.after.tau - exp.before.tau)[rows]
    return ChangeModel(exp.label, rows, y + measured, R,
                       thrust_configuration(profile.thrusters)[rows], b, a, measured, H,
                       hunting)


def _checked(post: ThrustMapPosterior, exp: Experiment | FloatReference,
             model: ChangeModel, profile: Profile) -> Outcome:
    """Whether ``exp`` agrees with ``post``, and what to say of it. Two tests of its
    innovation v (covariance S), each at half :data:`REJECT_P`, so that an experiment that
    agrees is rejected at most that often: its χ² (anything amiss: a wrong slot, a piece
    not fitted), and its component along d, the change of τ the recorded ballast makes
    (the thrusters saw 1 + s times it: the pieces weigh other than recorded, an inventory
    entry wrong by a factor, the issue's own example), ŝ = −dᵀS⁻¹v / dᵀS⁻¹d ± (dᵀS⁻¹d)^-½,
    the more sensitive test of the two for that one alternative (one degree of freedom
    against the χ²'s three)."""
    from scipy.stats import chi2, norm  # 1 s to import: only when a calibration is checked

    v, S = innovation(model, profile, post.mean, post.cov)
    a = exp.hold if isinstance(exp, FloatReference) else exp.after
    d = (restoring_matrix(a.phi_rad, a.theta_rad) @ ballast_change(profile, exp.change)[0]
         )[model.rows]
    S_inv_v = np.linalg.solve(S, v)
    d2 = float(v @ S_inv_v)
    info = float(d @ np.linalg.solve(S, d))     # 0: pieces whose changes cancel exactly
    p_scale, saw = 1.0, ""
    if info > 0:
        scale, scale_sd = -float(d @ S_inv_v) / info, 1.0 / math.sqrt(info)
        p_scale = float(2 * norm.sf(abs(scale) / scale_sd))
        saw = (f"; the thrusters saw {1 + scale:.1%} ± {scale_sd:.1%} of the change the "
               "recorded ballast makes")
    p = min(1.0, 2 * min(float(chi2.sf(d2, len(v))), p_scale))
    sigma = float(norm.isf(p / 2)) if p > 0 else math.inf
    about = f"≈ {sigma:.1f}σ" if math.isfinite(sigma) else "beyond 37σ"  # p below 1e-300
    z = v / np.sqrt(np.diag(S))
    worst = int(np.argmax(np.abs(z)))
    row = _ROW_NAMES[int(np.flatnonzero(model.rows)[worst])]
    unit = "N" if row.startswith("Z") else "N·m"
    off = (f"{row} off by {v[worst]:+.3g} {unit} = {z[worst]:+.1f}σ of its predicted "
           f"± {math.sqrt(S[worst, worst]):.2g} {unit}{saw}")
    if p < REJECT_P:
        earlier = (f"{post.experiments} earlier experiment(s)" if post.experiments
                   else "the profile's thrust map")
        return Outcome(exp.label, False, d2, len(v), sigma, (
            f"calibration experiment {exp.label!r} disagrees with {earlier}: {off} "
            f"(χ² {d2:.1f} on {len(v)} rows and the scale together {about}); rejected, "
            "not learnt: "
            f"{_what_to_check(profile, exp)}"))
    return Outcome(exp.label, True, d2, len(v), sigma,
                   f"calibration experiment {exp.label!r} learnt ({off}; {about})")


def edges_of(experiments: Sequence[Experiment | FloatReference], profile: Profile
             ) -> list[EdgeObservation]:
    """The dead-band edges the experiments' holds show by hunting
    (:mod:`trimd.core.hunting`): what the holds teach of the bands whatever the ballast
    change, so a rejected experiment's too."""
    return [o for exp in experiments for h in _holds(exp) if h.outputs is not None
            for o in readable_edges(spikes_seen(h.outputs, profile), profile)]


def _holds(exp: Experiment | FloatReference) -> tuple[CalibrationHold, ...]:
    return (exp.hold,) if isinstance(exp, FloatReference) else (exp.before, exp.after)


def update(post: ThrustMapPosterior, exp: Experiment | FloatReference, profile: Profile
           ) -> tuple[ThrustMapPosterior, Outcome]:
    """``post`` updated by ``exp`` (the fit with ``post`` as its prior), or ``post``
    unchanged when ``exp`` disagrees with it (:func:`_checked`), with the outcome."""
    post = observed_bands(post, edges_of([exp], profile), profile) or post
    model = change_model(exp, profile)
    outcome = _checked(post, exp, model, profile)
    if not outcome.accepted:
        return post, outcome
    mean, cov = fit([model], profile, Gaussian(post.mean, post.sqrt_cov), post.mean)
    return posterior(mean, cov, post.experiments + 1), outcome


@dataclass(frozen=True, eq=False)
class Calibration:
    """The posterior of a sequence of experiments and what became of each."""

    posterior: ThrustMapPosterior
    outcomes: tuple[Outcome, ...]

    @property
    def rejected(self) -> tuple[Outcome, ...]:
        """The experiments left out as inconsistent."""
        return tuple(o for o in self.outcomes if not o.accepted)


def calibrate(experiments: Sequence[Experiment | FloatReference], profile: Profile
              ) -> Calibration:
    """The profile's prior updated by ``experiments`` in order, each inconsistent one left
    out (and said so in its :class:`Outcome`): each is checked against those accepted
    before it, then all accepted are fitted afresh from the prior."""
    post = observed_bands(prior(profile), edges_of(experiments, profile), profile) or prior(
        profile)
    outcomes: list[Outcome] = []
    accepted: list[ChangeModel] = []
    start = Gaussian(post.mean, post.sqrt_cov)
    for exp in experiments:
        model = change_model(exp, profile)
        outcome = _checked(post, exp, model, profile)
        outcomes.append(outcome)
        if outcome.accepted:
            accepted.append(model)
            mean, cov = fit(accepted, profile, start, post.mean)
            post = posterior(mean, cov, len(accepted))
    return Calibration(post, tuple(outcomes))
