"""The thrust map learns (issue 24, docs/method.md §7): one deliberate calibration, then a
new trim of the same simulated vehicle, judged by its TRUE net quantities.

Per seed and case (:data:`bench.bench_sim_coverage.CASES`; a vehicle that its profile
does not describe exactly, ``truth=perturbed``: thrust curves 5 % off, ESC bands up to
4 µs off with outputs hunting at their edge): a full trim with the profile alone
(:func:`tests.helpers.sim_trim`); a deliberate calibration of the same vehicle
(:func:`trimd.app.calibrate.calibrate_with_weights`, ``trimd calibrate``'s use case, into a
trim history of the seed's own): the series :data:`SERIES`, a level hold, then the known
weight of :data:`WEIGHTS` — pieces of the profile's inventory, their net weight in water
and its 1σ as the inventory says — and a float of the same lift (its 1σ
:data:`FLOAT_PCT`) at each corner in turn, one level hold each; the trim again with the
calibrated profile (:func:`trimd.app.history.calibration.calibrated_profile`). The
vehicle is the seed's (``truth_seed``), each calibration hold's noise and disturbances
another dive's (``seed`` + k·:data:`NOISE`); both trims fly the seed's own, so that they
differ by the calibration alone. Then a second calibration, of the weight alone, whose
weight is :data:`HEAVIER` times what it is declared to be (the inventory entry 10 %
light): it must be rejected as inconsistent, checked against the first (and, for
comparison, against the profile's own thrust map).

Printed per case: the RMS error of W − B [N] and of the three net moments in
mm-equivalent (error / nominal weight, as :mod:`bench.bench_sim_coverage`) and the share
of 95 % intervals covering the truth, without and with the calibration, beside issue 24's
targets (:data:`TARGETS`); the mean ± of each; how many calibrations were learnt whole
and which thrust-map parameters they narrowed; how many wrong-weight calibrations were
rejected. With ``TRIMD_CALIB_KNOWN`` (comma-separated groups of :data:`GROUPS`: what the
calibration left of the error, docs/method.md §7) the calibrated trim again per group, its
posterior's parameters of that group set to the simulated vehicle's truth
(:func:`trimd.drivers.sim.truth.thrust_map_errors`) with a σ of :data:`EXACT_STD`. With
``TRIMD_CALIB_FLOAT=1`` (at the tiny size too) the calibrated trim again after what the
loop's trim → apply → verify → float teaches is added to the calibration: the experiment
of the first trim's ballast fitted (a level hold before, one after), then also the float
reference (:mod:`trimd.core.float_reference`: that second hold and a float), each hold
another dive of the same vehicle, then also the band calibration of the ballasted vehicle
(``trimd calibrate --band``: :func:`banded`); each experiment stored in (a copy of) the
seed's history and the calibration recomputed from them all, as trimd gives it to every
later trim of the vehicle; with ``TRIMD_CALIB_KNOWN`` too, that last calibration again per
group, its parameters of the group true (what the loop leaves).

``TRIMD_CALIB_SEEDS`` (default 60) seeds per case; ``TRIMD_CALIB_OPTIONS`` the sim options
(default :data:`OPTIONS`); ``TRIMD_CALIB_HOLD_S`` how long each calibration hold collects
[s] (``trimd calibrate --hold-s``; default: the profile's ``collect_max_s``; the trims
collect as always); ``TRIMD_CALIB_WEIGHT_COUNT`` how many of its piece the known weight
is (default: :data:`WEIGHTS`); ``TRIMD_CALIB_KNOWN`` the groups above (default none; at the tiny
size ``vertical``); ``TRIMD_CALIB_CASES`` comma-separated words picking cases;
``TRIMD_COVERAGE_PROCESSES`` (default 1) worker processes. One seed takes ≈ 50 s (Heavy)
and ≈ 60 s (Sabertooth) of one core: two trims and eleven level holds of
``collect_max_s``. At the tiny size the series is its first weight.
"""

from __future__ import annotations

import asyncio
import os
import shutil
import tempfile
from collections import Counter
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from bench.bench_sim_coverage import (
    CASES,
    NAMES,
    Run,
    coverage,
    judge,
    picked,
    rms_errors,
    run_seeds,
    seeding,
)
from bench.size import size, sized_profile
from tests.helpers import SimTrim, sim_apply_experiment, sim_float_reference, sim_trim
from trimd.app.calibrate import calibrate_with_weights
from trimd.app.calibration_loads import CalibrationRun, KnownWeight, Load
from trimd.app.connect import open_link
from trimd.app.history import History
from trimd.app.history.calibration import calibrated_profile, store_experiment
from trimd.ballast.band import unhunted
from trimd.core.calibration import Experiment, prior, update
from trimd.core.calibration import calibrate as recalibrate
from trimd.core.calibration_json import experiment_from_dict
from trimd.core.errors import EstimationError, LinkError, UsageError
from trimd.core.float_reference import FloatReference
from trimd.core.hunting import LIFTING
from trimd.core.learnt import DETERMINED
from trimd.core.link import Link
from trimd.core.map_posterior import ThrustMapPosterior, posterior
from trimd.core.output_hist import spikes_seen
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.types import FloatArray
from trimd.drivers.sim.config import parse_sim_options
from trimd.drivers.sim.truth import perturb_profile, thrust_map_errors
from trimd.drivers.sim.vehicle import SimVehicle

OPTIONS = "disturb=real,truth=perturbed"
#: profile → the known weight of its calibration: inventory piece, count, slot. Weights
#: in a corner (all three level rows, Z, K, M, move), enough to move the thrusters well
#: out of their dead band (on the Heavy the 5.4 N cross it whatever the buoyancy: W − B ≈
#: 0.3 ± 1.4 N before). What a gain error shows is the thrust change times the error, so
#: the Sabertooth's weight is 1.5 % of the vehicle's (178 N; 60 seeds, docs/method.md §7:
#: against 4.55 kg, z net 1.12 → 0.77 mm-equivalent, a 10 % heavier weight caught in 32
#: → 59 of 60); the Heavy's twice as heavy (1.09 kg, 30 seeds) gained nothing
#: (``TRIMD_CALIB_WEIGHT_COUNT`` tries another).
WEIGHTS = {"bluerov2-heavy": ("lead-200g", 3, "W-front-stbd"),
           "sabertooth-dh2": ("lead-1kg", 20, "FrontSB")}
#: profile → the calibration's series in order: (slot, +1 the known weight of
#: :data:`WEIGHTS`, −1 a float of the same lift), a weight and a float at each corner, so
#: that the vertical thrusters work on both sides of their dead bands (docs/method.md §7).
SERIES = {"bluerov2-heavy": (("W-front-stbd", 1), ("W-aft-port", -1), ("W-front-port", 1),
                             ("W-aft-stbd", -1), ("W-front-stbd", -1), ("W-aft-port", 1),
                             ("W-front-port", -1), ("W-aft-stbd", 1)),
          "sabertooth-dh2": (("FrontSB", 1), ("AftP", -1), ("FrontP", 1), ("AftSB", -1),
                             ("FrontSB", -1), ("AftP", 1), ("FrontP", -1), ("AftSB", 1))}
#: A float's 1σ [% of its lift].
FLOAT_PCT = 5.0
#: profile → issue 24's targets after one calibration, RMS over the seeds: W − B [N]
#: (None: none stated) and each net moment [mm-equivalent].
TARGETS: dict[str, tuple[float | None, float]] = {"bluerov2-heavy": (0.1, 0.3),
                                                  "sabertooth-dh2": (None, 0.1)}
#: The rows of the calibrated trims after the loop's experiments (:func:`referenced`).
LOOP = ("+ apply", "+ apply + float", "+ apply + float + band up", "+ apply + float + band")
#: The wrong-weight calibration's true weight / declared weight.
HEAVIER = 1.1
#: The noise seed of a calibration's k-th hold: seed + k·NOISE (another dive).
NOISE = 100_000
#: The blocks of the thrust map's parameters (calibration.ThrustMapPosterior's order).
BLOCKS = ("gain fwd", "gain rev", "band lo", "band hi")
#: The float reference's depth envelope [m] (``trimd float --max-depth-excursion``): the
#: ballasted vehicle is near neutral buoyancy, not at it.
FLOAT_EXCURSION_M = 10.0
#: The σ of a thrust-map parameter known exactly [prior σ].
EXACT_STD = 1e-3


def _bands(vertical: bool) -> Callable[[Profile], list[int]]:
    def index(profile: Profile) -> list[int]:
        n = len(profile.thrusters)
        picked = [i for i, t in enumerate(profile.thrusters)
                  if (abs(t.direction[2]) >= LIFTING) == vertical]
        return [2 * n + i for i in picked] + [3 * n + i for i in picked]
    return index


#: Groups of thrust-map parameters (``TRIMD_CALIB_KNOWN``): word → label and the indices
#: of its parameters in z (:mod:`trimd.core.curve_error`). Vertical: a thruster whose
#: thrust is at least :data:`~trimd.core.hunting.LIFTING` along z.
GROUPS: dict[str, tuple[str, Callable[[Profile], list[int]]]] = {
    "vertical": ("vertical bands", _bands(True)),
    "horizontal": ("horizontal bands", _bands(False)),
    "gains": ("gains", lambda p: list(range(2 * len(p.thrusters))))}


def pinned(post: ThrustMapPosterior, z: FloatArray, index: Sequence[int]
           ) -> ThrustMapPosterior:
    """``post`` with the parameters ``index`` known: their mean ``z[index]``, their σ
    :data:`EXACT_STD`, uncorrelated with the rest."""
    mean, cov = post.mean.copy(), post.cov.copy()
    i = list(index)
    mean[i] = z[i]
    cov[i, :] = 0.0
    cov[:, i] = 0.0
    cov[i, i] = EXACT_STD**2
    return posterior(mean, cov, post.experiments)


def with_float() -> bool:
    """``TRIMD_CALIB_FLOAT`` (default: 0; at the tiny size 1): the float reference too."""
    return os.environ.get("TRIMD_CALIB_FLOAT", size("0", "1")) == "1"


def known_groups() -> list[str]:
    """The groups ``TRIMD_CALIB_KNOWN`` names (module docstring); ValueError naming an
    unknown one."""
    words = [w.strip() for w in os.environ.get("TRIMD_CALIB_KNOWN", size("", "vertical")
                                               ).split(",") if w.strip()]
    if unknown := [w for w in words if w not in GROUPS]:
        raise ValueError(f"TRIMD_CALIB_KNOWN: no group {', '.join(unknown)} "
                         f"(the groups: {', '.join(GROUPS)})")
    return words


@dataclass(frozen=True)
class Seed:
    """One seed of a case: the trim without and with the calibration (``after`` None when
    the calibration did not end with an experiment); the calibration's outcome ("learnt",
    "rejected" or why there was none) and its σ; how many of each of :data:`BLOCKS` it
    narrowed below :data:`DETERMINED` of the prior σ; the wrong-weight calibration's
    outcome against the first one and against the profile alone and its σ; the
    calibrated trim per group of :func:`known_groups`, that group known; the calibration's
    error in each thrust-map parameter in units of its posterior σ, (μ − z)/σ; per trim
    (without, with) the shares of the variance of W − B and of each net moment that
    collecting longer would reduce (``q_cov_noise``) and that rests on the dead bands
    (``q_cov_band``), those of W − B, x, y, z net in that order (the rest: the curves'
    gains, the attitude reference, the drift model); with :func:`with_float` the
    calibrated trim after the apply experiment and after it and the float reference
    (:func:`referenced`), and what became of those two."""

    seed: int
    before: Run
    after: Run | None = None
    calibration: str = ""
    sigma: float = float("nan")
    narrowed: tuple[int, ...] = (0, 0, 0, 0)
    wrong: str = ""
    wrong_prior: str = ""
    wrong_sigma: float = float("nan")
    shares: tuple[tuple[float, ...], ...] = ()
    known: tuple[Run, ...] = ()
    standardised: tuple[float, ...] = ()
    looped: tuple[Run, ...] = ()
    reference: str = ""
    unshown: tuple[str, ...] = ()


def known_weight(profile: Profile) -> KnownWeight:
    """The calibration's weight (:data:`WEIGHTS`) as ``trimd calibrate --mass`` takes it:
    net kg in water at its slot, 1σ the piece's own."""
    name, count, slot = WEIGHTS[profile.name]
    count = int(os.environ.get("TRIMD_CALIB_WEIGHT_COUNT", count))
    piece = profile.piece(name)
    return KnownWeight(count * piece.net_down_N(profile.water_density_kg_m3, 1.0), slot,
                       piece.net_uncertainty_pct)


def series(profile: Profile, count: int) -> list[KnownWeight]:
    """The first ``count`` weights of the profile's :data:`SERIES`."""
    weight = known_weight(profile)
    return [KnownWeight(sign * weight.kg, slot,
                        weight.uncertainty_pct if sign > 0 else FLOAT_PCT)
            for slot, sign in SERIES[profile.name][:count]]


def calibrate(profile: Profile, payload: str, seed: int, options: str,
              weights: Sequence[KnownWeight], hung_kg: Sequence[float], first: int,
              db: Path, hold_s: float | None = None) -> CalibrationRun:
    """A deliberate calibration with the series ``weights`` declared and ``hung_kg`` [kg in
    water] hung instead, of the vehicle of ``seed``, its holds the dives
    ``seed + (first + k)·NOISE`` of ``hold_s`` each (None: the profile's
    ``collect_max_s``), checked against the calibration stored in ``db`` and stored
    there."""
    opened: list[str] = []

    def opener() -> Awaitable[Link]:
        extra = ""
        if opened:
            w = weights[len(opened) - 1]
            x, y, z = profile.slot(w.slot).position_m
            extra = f"+{hung_kg[len(opened) - 1]:.6f}@{x},{y},{z}"
        opened.append(extra)
        return open_link(f"sim:payload={payload}{extra},seed={seed + (first + len(opened)) * NOISE}"
                         f",truth_seed={seed},{options}", profile)

    calibrated = calibrated_profile(db, "bench", profile)
    return asyncio.run(calibrate_with_weights(opener, calibrated, [(w,) for w in weights],
                                              lambda _text, _load: True,
                                              db=db, vehicle="bench", wall_clock=False,
                                              hold_s=hold_s))


def judged_trim(profile: Profile, payload: str, seed: int, options: str,
                estimate_with: Callable[[SimVehicle], Profile] | None = None
                ) -> tuple[Run, tuple[float, ...], SimTrim]:
    """The trim of ``seed`` judged, the noise and band shares of the variance of q
    (:class:`Seed`; NaN when it did not end with an estimate), and the trim;
    ``estimate_with`` as :func:`tests.helpers.sim_trim`'s."""
    trial = sim_trim(profile, payload, seed, options, estimate_with=estimate_with)
    est = trial.result.estimate
    share = np.full(8, np.nan)
    if est is not None and est.q_cov_noise is not None and est.q_cov_band is not None:
        share = np.r_[np.diag(est.q_cov_noise), np.diag(est.q_cov_band)] / np.tile(
            np.diag(est.q_cov), 2)
    return judge(seed, trial), tuple(map(float, share)), trial


def referenced(profile: Profile, payload: str, seed: int, options: str, trial: SimTrim,
               db: Path, first: int) -> tuple[tuple[Profile, ...], str, tuple[str, ...]]:
    """The calibrated profile after what the loop after ``trial`` teaches, each stored in
    the history ``db`` beside the calibration there and the calibration recomputed from
    them all, as every later trim of the vehicle gets it
    (:func:`~trimd.app.history.calibration.calibrated_profile`): the experiment of its
    proposal's ballast fitted (:func:`tests.helpers.sim_apply_experiment`, from a level
    hold of the vehicle as trimmed to one of it ballasted), then also the float reference
    of the ballasted vehicle (that hold and a float:
    :func:`tests.helpers.sim_float_reference`), then also the band calibration of the
    ballasted vehicle (:func:`banded`): its upper edges' experiments, then all;
    the dives ``seed + (first + k)·NOISE`` of the same vehicle, never the trim's own;
    what became of each; the band calibration's sides that ended with an edge unshown."""
    vehicle = f"truth_seed={seed},{options}"
    made = sim_float_reference(trial, payload, seed + first * NOISE,
                               seed + (first + 1) * NOISE, vehicle, FLOAT_EXCURSION_M)
    if made.reference is None:
        same = calibrated_profile(db, "bench", profile)
        return (same,) * 4, made.reason, ()
    exp = sim_apply_experiment(trial, payload, made.reference.hold,
                               seed + (first + 2) * NOISE, vehicle)
    learnt: list[Profile] = []
    told: list[str] = []
    for what, e in (("apply", exp), ("float", made.reference)):
        with History(db) as history:
            outcome = store_experiment(history, "bench", profile, e)[1]
        told.append(f"{what} {_verdict(outcome.accepted)}")
        learnt.append(calibrated_profile(db, "bench", profile))
    before = len(_experiments(db))
    text, ups, unshown = banded(learnt[-1], made.payload, seed, first + 3, vehicle, db)
    told.append(f"band {text}")
    upper = recalibrate(_experiments(db)[:before + ups], profile).posterior
    return (learnt[0], learnt[1], replace(profile, thrust_map=upper),
            calibrated_profile(db, "bench", profile)), ", ".join(told), unshown


def _experiments(db: Path) -> list[Experiment | FloatReference]:
    """The experiments stored in the history ``db``, in order."""
    with History(db) as history:
        return [experiment_from_dict(r.values["experiment"], str(db))
                for r in history.experiments("bench")]


def banded(profile: Profile, ballasted: str, seed: int, first: int, vehicle: str, db: Path
           ) -> tuple[str, int, tuple[str, ...]]:
    """The band calibration (``trimd calibrate --band``) of the simulated vehicle of
    ``seed`` with ``ballasted`` aboard and ``profile`` (the vehicle's calibration in the
    history ``db``), its holds the dives ``seed + (first + k)·NOISE``, its experiments
    (the upper edges', then the lower edges', each side's load aimed again while a hold
    misses an edge) stored in ``db``: what became of each, its side and how many of the
    lifting thrusters' edges on that side its second hold showed; how many were the upper
    edges'; and the sides ("upper", "lower") whose last hold still missed an edge."""
    loads: list[Load] = []

    def opener() -> Awaitable[Link]:
        hung = loads[-1] if loads else ()       # each load swapped for the next
        extra = "".join(f"+{w.kg:.6f}@{x},{y},{z}" for w in hung
                        for x, y, z in [profile.slot(w.slot).position_m])
        return open_link(f"sim:payload={ballasted}{extra},"
                         f"seed={seed + (first + len(loads)) * NOISE},{vehicle}", profile)

    def hang(_text: str, load: Load) -> bool:
        loads.append(load)
        return True

    try:
        done = asyncio.run(calibrate_with_weights(opener, profile, (), hang, db=db,
                                                  vehicle="bench", wall_clock=False,
                                                  band_pct=1.0))
    except (EstimationError, LinkError, UsageError) as exc:
        return f"failed: {exc}", 0, ()
    edges = [_edges_shown(exp, profile, up) for exp, up in zip(done.experiments, done.sides,
                                                                strict=True)]
    text = " + ".join(f"{_verdict(o.accepted)} ({'up' if up else 'down'}, {shown}/{of} edges)"
                      for o, up, (shown, of) in zip(done.outcomes, done.sides, edges,
                                                    strict=True))
    last_missed = {up: shown < of for up, (shown, of) in zip(done.sides, edges, strict=True)}
    unshown = tuple(side for up, side in ((True, "upper"), (False, "lower"))
                    if last_missed.get(up, False))
    return text, sum(done.sides), unshown


def _edges_shown(exp: Experiment, profile: Profile, upward: bool) -> tuple[int, int]:
    """How many of the lifting thrusters' edges on its side the band experiment's second
    hold showed, and how many lifting thrusters there are."""
    lifting = len(unhunted(profile, [], upward))
    after = exp.after.outputs
    missed = lifting if after is None else len(unhunted(profile, spikes_seen(after, profile),
                                                        upward))
    return lifting - missed, lifting


def _verdict(accepted: bool) -> str:
    return "learnt" if accepted else "rejected"


def run(name: str, payload: str, seed: int, options: str, hold_s: float | None = None
        ) -> Seed:
    """The seed (module docstring), each calibration hold collecting ``hold_s`` [s] (None:
    the profile's ``collect_max_s``); at the tiny size each hold collects for less
    (:func:`bench.size.sized_profile`)."""
    profile = sized_profile(load_profile(name))
    before, before_share, trial = judged_trim(profile, payload, seed, options)
    weights = series(profile, size(len(SERIES[name]), 1))
    with tempfile.TemporaryDirectory() as tmp:
        db = Path(tmp) / "trimd.db"
        try:
            good = calibrate(profile, payload, seed, options, weights,
                             [w.kg for w in weights], 0, db, hold_s)
        except (EstimationError, LinkError) as exc:
            return Seed(seed, before, calibration=f"no experiment: {exc}",
                        shares=(before_share,))
        calibrated = calibrated_profile(db, "bench", profile)
        post = calibrated.thrust_map or prior(profile)
        truth = thrust_map_errors(profile, perturb_profile(
            profile, parse_sim_options(f"seed={seed},{options}"))[1])
        sd = np.sqrt(np.diag(post.cov)).reshape(len(BLOCKS), -1)
        narrowed = tuple(int(n) for n in np.sum(sd < DETERMINED, axis=1))
        after, after_share, _ = judged_trim(calibrated, payload, seed, options)
        looped: tuple[Run, ...] = ()
        reference = ""
        unshown: tuple[str, ...] = ()
        if with_float():
            loop_db = Path(tmp) / "loop.db"     # the wrong weight's check: as before
            shutil.copyfile(db, loop_db)
            profiles, reference, unshown = referenced(profile, payload, seed, options, trial,
                                                      loop_db, len(weights) + 4)
            looped = tuple(judged_trim(p, payload, seed, options)[0] for p in profiles)
            last = profiles[-1]
            looped += tuple(judged_trim(last, payload, seed, options, lambda _v, g=g: replace(
                last, thrust_map=pinned(last.thrust_map or prior(profile), truth,
                                        GROUPS[g][1](profile))))[0] for g in known_groups())
        learnt = sum(o.accepted for o in good.outcomes)
        out = Seed(seed, before, after, "learnt" if learnt == len(weights) else
                   f"{learnt} of {len(weights)} learnt", min(o.sigma for o in good.outcomes),
                   narrowed, shares=(before_share, after_share),
                   looped=looped, reference=reference, unshown=unshown,
                   known=tuple(judged_trim(calibrated, payload, seed, options, lambda _v, g=g:
                                           replace(calibrated, thrust_map=pinned(
                                               post, truth, GROUPS[g][1](profile))))[0]
                               for g in known_groups()),
                   standardised=tuple((post.mean - truth) / np.sqrt(np.diag(post.cov))))
        try:
            wrong = calibrate(profile, payload, seed, options, weights[:1],
                              [HEAVIER * weights[0].kg], len(weights) + 1, db, hold_s)
        except (EstimationError, LinkError) as exc:
            return replace(out, wrong=f"no experiment: {exc}")
    alone = update(prior(profile), wrong.experiments[0], profile)[1]
    return replace(out, wrong=_verdict(wrong.outcomes[0].accepted),
                   wrong_prior=_verdict(alone.accepted), wrong_sigma=wrong.outcomes[0].sigma)


def _count(values: list[str], what: str) -> str:
    return f"{sum(v == what for v in values)}/{len(values)}"


def _figures(label: str, runs: list[Run], profile: Profile,
             more: tuple[tuple[str, FloatArray, str], ...] = ()) -> list[str]:
    """The lines of ``runs``' RMS error, mean ± and coverage (and ``more``: what, values,
    format) for people."""
    rms = rms_errors(runs, profile.weight_N)
    done = [r.sigma[:4] for r in runs if r.sigma is not None]
    sigma = np.mean(done, axis=0) if done else np.full(4, np.nan)
    sigma[1:] *= 1e3 / profile.weight_N
    return [f"  {label:44s} {what:22s} " + " ".join(f"{v:{form}}" for v in values)
            for what, values, form in (("rms error (N, mm-eq)", rms, "8.3f"),
                                       ("mean ± 1σ (N, mm-eq)", sigma, "8.3f"),
                                       ("95 % interval covers", coverage(runs)[0][:4], "8.0%"),
                                       *more)]


def _edges_learnt(seeds: list[Seed], profile: Profile) -> list[str]:
    """How well the calibrations of ``seeds`` learnt each group of band edges
    (:data:`GROUPS`): the RMS of (μ − z)/σ and the share beyond 2σ."""
    if not seeds:
        return []
    z = np.array([s.standardised for s in seeds])
    out = []
    for word in ("vertical", "horizontal"):
        label, index = GROUPS[word]
        e = z[:, index(profile)]
        out.append(f"  {label}: calibration error / its σ RMS {np.sqrt(np.mean(e**2)):.2f}, "
                   f"beyond 2σ {np.mean(np.abs(e) > 2):.0%} (a normal: 5 %)")
    return out


def _worst(runs: list[tuple[int, Run]], count: int = 5) -> str:
    """The seeds of ``runs`` whose W − B is furthest off, each with its error and 1σ
    [N], for people: where to look first."""
    done = sorted(((seed, r.error[0], r.sigma[0]) for seed, r in runs
                   if r.error is not None and r.sigma is not None),
                  key=lambda e: -abs(e[1]))[:count]
    return "W − B furthest off with the whole loop: " + ", ".join(
        f"seed {seed} {e:+.3f} ± {sd:.3f} N" for seed, e, sd in done)


def report(seeds: list[Seed], profile: Profile) -> list[str]:
    """The figures of ``seeds`` for people (module docstring), one string per line."""
    calibrated = [s for s in seeds if s.after is not None]
    pairs = [s for s in calibrated if s.before.error is not None and s.after is not None
             and s.after.error is not None]
    target_wb, target_m = TARGETS[profile.name]
    lines = [f"{len(pairs)} of {len(seeds)} seeds with both trims done and a calibration",
             f"  {'':67s}" + " ".join(f"{n:>8s}" for n in NAMES[:4])]
    for k, label in enumerate(("uncalibrated", "calibrated")):
        runs = [r for s in pairs if (r := (s.before, s.after)[k]) is not None]
        share = np.nanmean([s.shares[k] for s in pairs], axis=0)
        lines += _figures(label, runs, profile, (("σ² share: noise", share[:4], "8.0%"),
                                                ("σ² share: dead band", share[4:], "8.0%")))
    for k, g in enumerate(known_groups()):
        lines += _figures(f"calibrated, {GROUPS[g][0]} true", [s.known[k] for s in pairs],
                          profile)
    if with_float():
        for k, label in enumerate((*LOOP, *(f"+ the loop, {GROUPS[g][0]} true"
                                            for g in known_groups()))):
            lines += _figures(f"calibrated {label}", [s.looped[k] for s in pairs
                                                      if s.looped], profile)
        lines.append("  the loop's experiments: " + ", ".join(
            f"{n} {v}" for v, n in Counter(s.reference for s in pairs).most_common()))
        whole = LOOP.index("+ apply + float + band")
        lines.append("  " + _worst([(s.seed, s.looped[whole]) for s in pairs if s.looped]))
        lines.append("  band series ending with an edge unshown: " + "; ".join(
            f"{side} side, seeds " + (", ".join(str(s.seed) for s in pairs
                                                if side in s.unshown) or "none")
            for side in ("upper", "lower")))
    wb = "—" if target_wb is None else f"{target_wb:.3g} N"
    lines.append(f"  issue 24's targets (rms, calibrated): W − B {wb}, each net moment "
                 f"{target_m:.3g} mm-equivalent; coverage 90–99 %")
    outcomes = [s.calibration for s in seeds]
    narrowed = np.array([s.narrowed for s in seeds if s.calibration == "learnt"]).reshape(
        -1, len(BLOCKS))
    lines.append(f"  calibration learnt {_count(outcomes, 'learnt')} (rejected "
                 f"{_count(outcomes, 'rejected')}); parameters narrowed below "
                 f"{DETERMINED:.0%} of the prior σ, mean per seed of "
                 f"{len(profile.thrusters)} each: " + ", ".join(
                     f"{b} {v:.1f}" for b, v in zip(BLOCKS, narrowed.mean(axis=0)
                                                    if len(narrowed) else [np.nan] * 4,
                                                    strict=True)))
    lines += _edges_learnt([s for s in seeds if s.calibration == "learnt"], profile)
    wrong = [s for s in seeds if s.wrong in ("learnt", "rejected")]
    lines.append(f"  weight {HEAVIER:.0%} of its declared value: rejected "
                 f"{_count([s.wrong for s in wrong], 'rejected')} after the calibration, "
                 f"{_count([s.wrong_prior for s in wrong], 'rejected')} against the profile "
                 f"alone; its σ median {np.median([s.wrong_sigma for s in wrong]):.1f}"
                 if wrong else "  weight heavier than declared: no experiment")
    done = {s.seed for s in pairs}
    for s in [s for s in seeds if s.seed not in done or s.wrong not in ("learnt", "rejected")
              ][:size(5, 1)]:
        lines.append(f"  seed {s.seed}: trim {s.before.outcome[:50]}; calibration "
                     f"{s.calibration[:60]}; wrong weight {s.wrong[:60]}")
    return lines


def main() -> None:
    cfg = seeding("CALIB", size(60, 1), OPTIONS)
    known_groups()   # a group it does not know stops it before any seed runs
    seeds, options = cfg.seeds, cfg.options
    held = os.environ.get("TRIMD_CALIB_HOLD_S")
    hold_s = float(held) if held else None
    for name, payload in picked(size(CASES, CASES[:1]), cfg.wanted):
        runs, wall = run_seeds(run, name, payload, seeds, options, cfg.processes,
                               [hold_s] * seeds)
        length = (f"{hold_s:g} s" if hold_s else
                  f"the profile's {load_profile(name).procedure.collect_max_s:g} s")
        print(f"{name}, {payload}, sim:{options}, calibration: "
              f"{known_weight(load_profile(name)).kg:.3f} kg and a float of its lift at each "
              f"corner, {size(len(SERIES[name]), 1)} in all, holds of {length}: {seeds} "
              f"seeds, {wall:.1f} s wall per seed")
        for line in report(runs, load_profile(name)):
            print(f"  {line}")
