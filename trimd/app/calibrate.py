"""A deliberate calibration of the thrust map (``trimd calibrate``, docs/method.md §7): a
level hold, the operator hangs a known weight at a known ballast slot, a second level
hold; optionally a series: the operator then swaps the weight for the next known one
(another slot, a float) before each further level hold; a step of the series may hang
several weights at once. Each two consecutive holds and
the change of weight between them are a calibration experiment, checked against the
vehicle's calibration so far (and the series' earlier experiments) and stored in its trim
history like those of ``ballast apply`` and a verify hold
(:mod:`trimd.app.history.calibration`). A weight and a float at each corner make the
vertical thrusters cross their dead band, whose edges the fit then sees. The band
calibration (``trimd calibrate --band``, for a trimmed vehicle) chooses its two steps
after the first hold: the load that makes the vehicle just heavy enough for its vertical
thrusters to hunt at the upper edges of their bands (:mod:`trimd.ballast.band`), which the
second hold then shows, then the one that makes it just buoyant enough for the lower
edges, which the third shows.

Each hold is a session of its own on the link opened again (the verify hold's
procedure: the profile's first hold, level), so the vehicle is released while the weight
is hung, and a recording of its own that says which hold of the series it is and what
weights the series hangs: :func:`trimd.app.replay.replay_calibration` reproduces the
experiments and their outcomes from them. Each collects for the profile's whole
``collect_max_s``, not until the trim's stop rule is met: that rule stops once the noise
is below the thrust map's share of the ±, while the experiment's noise is what it cannot
tell from the thrust map's errors (on the simulated Sabertooth a level hold's mean Z
± 2.6–18 N after 10 s, ≈ 0.9 N after 180 s). Confirmation is the caller's: every hold
commands the vehicle without asking again.
"""

from __future__ import annotations

import math
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Never

from trimd.app.history import History
from trimd.app.history.calibration import store_experiment
from trimd.app.session import Presenter, Recorder, Session
from trimd.ballast.band import band_load
from trimd.core.calibration import (
    Experiment,
    Outcome,
    PieceChange,
    ThrustMapPosterior,
    ballast_change,
    calibration_hold,
    prior,
    update,
)
from trimd.core.errors import DataError, EstimationError, UsageError
from trimd.core.estimate import HoldSamples
from trimd.core.events import Phase
from trimd.core.link import Link
from trimd.core.procedure import Procedure
from trimd.core.profile import Profile
from trimd.core.segment import estimate_segment

__all__ = ["LIGHT_SHARE", "MIN_HOLD_S", "CalibrationRun", "KnownWeight", "Load",
           "calibrate_with_weights", "calibration_experiment", "check_against_profile",
           "checked_hold_s", "hold_from_record", "hold_record", "level_hold_procedure",
           "light_weight_advice", "recorded_hold_s", "swap_text"]

#: The two holds of a one-weight calibration as recordings before the series named them.
_OLD_HOLDS = ("before", "after")
#: The shortest level hold a calibration collects for [s].
MIN_HOLD_S = 10.0
#: The share of the vehicle's mass below which a calibration's heaviest weight teaches
#: little: a gain error shows as the thrust change times the error. On the simulated
#: Sabertooth (1184 kg) a series of 4.55 kg left a later trim's z net at 1.12
#: mm-equivalent and caught a 10 % heavier weight in 32 of 60; one of 18.2 kg (1.5 %) at
#: 0.77 and in 59 of 60 (docs/method.md §7).
LIGHT_SHARE = 0.01
#: 1σ of the height of the centre of gravity's net moment [N·m] assumed for the level
#: fit's q, which enters only through the two holds' small difference in attitude.
_M_Z_STD = 1.0


@dataclass(frozen=True)
class KnownWeight:
    """A weight hung for a calibration: its net downward force in water as ``kg``
    [kgf; negative: a float's lift], at ballast slot ``slot``, known to
    ``uncertainty_pct`` [%, 1σ]."""

    kg: float
    slot: str
    uncertainty_pct: float = 1.0


#: The weights hung together for one hold of a series (usually one).
Load = tuple[KnownWeight, ...]


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """A deliberate calibration's experiments in order, what became of each, the
    vehicle's calibration after them, the profile they were made with, and why the series
    stopped early ("" when it ran to its end)."""

    experiments: tuple[Experiment, ...]
    outcomes: tuple[Outcome, ...]
    posterior: ThrustMapPosterior
    profile: Profile
    stopped: str = ""


def level_hold_procedure(profile: Profile, *, confirmed: bool, hold_s: float | None = None
                         ) -> Procedure[Never, HoldSamples]:
    """A calibration's level hold: the verify hold's procedure (the profile's first hold,
    level) collected for ``hold_s`` [s] (None: the profile's whole ``collect_max_s``,
    module docstring), whose result is the hold's samples."""
    if hold_s is not None:
        profile = replace(profile, procedure=replace(profile.procedure, collect_max_s=hold_s))
    return Procedure(profile, confirmed=confirmed, verify=_the_hold,
                     collect_s=profile.procedure.collect_max_s)


def _the_hold(hold: HoldSamples) -> HoldSamples:
    return hold


def _weight_dict(w: KnownWeight) -> dict[str, object]:
    return {"kg": w.kg, "slot": w.slot, "uncertainty_pct": w.uncertainty_pct}


def hold_record(index: int, series: Sequence[Load], hold_s: float | None = None,
                band: bool = False) -> dict[str, object]:
    """What a calibration hold's recording says of itself: which hold of the series it is
    (0: before any weight), the series' loads in order (one weight as its dict, several
    as a list of them; a band calibration's first hold, made before its load is chosen:
    none), whether it is a band calibration and, when the operator chose it, how long
    each hold collects [s]."""
    return {"hold": index, "weights": [_weight_dict(load[0]) if len(load) == 1 else
                                       [_weight_dict(w) for w in load] for load in series],
            **({"band": True} if band else {}),
            **({"hold_s": hold_s} if hold_s is not None else {})}


def _hold_s_ok(hold_s: float) -> bool:
    return math.isfinite(hold_s) and hold_s >= MIN_HOLD_S


def checked_hold_s(hold_s: float | None) -> float | None:
    """``hold_s`` [s] (``trimd calibrate --hold-s``) when it is None or a length a level
    hold can collect for; UsageError otherwise."""
    if hold_s is not None and not _hold_s_ok(hold_s):
        raise UsageError(f"--hold-s {hold_s:g}: a level hold collects for at least "
                         f"{MIN_HOLD_S:g} s", "trimd calibrate")
    return hold_s


def light_weight_advice(profile: Profile, weights: Sequence[KnownWeight]) -> str | None:
    """What to hang instead when the heaviest of ``weights`` (net in water [kgf]) is
    lighter than :data:`LIGHT_SHARE` of ``profile``'s mass [kg]; None when it is not."""
    heaviest = max((abs(w.kg) for w in weights), default=0.0)
    least = LIGHT_SHARE * profile.mass_kg
    if heaviest >= least:
        return None
    return (f"the heaviest weight, {heaviest:g} kg in water, is "
            f"{100 * heaviest / profile.mass_kg:.2g} % of the vehicle's {profile.mass_kg:g} "
            f"kg: a thruster's gain error shows as the thrust change times the error, so "
            f"this calibration will learn little and may not catch a wrong inventory entry; "
            f"a weight of {least:.3g} kg or more ({100 * LIGHT_SHARE:g} %) teaches more "
            f"(docs/method.md §7)")


def recorded_hold_s(d: dict[str, object], source: str) -> float | None:
    """How long the calibration hold of :func:`hold_record`'s dict collected [s]; None
    when it does not say (the profile's ``collect_max_s``, as every recording before
    2026-11-29). DataError naming ``source`` when it says something else."""
    value = d.get("hold_s")
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not _hold_s_ok(
            float(value)):
        raise DataError(f"{source}: the recorded calibration hold's length is malformed "
                        f"({value!r}; a level hold collects for at least {MIN_HOLD_S:g} s)")
    return float(value)


def _load_of(d: object) -> Load | None:
    """A load as :func:`hold_record` writes it (a weight's dict, or a list of them)."""
    weights = [_weight_of(w) for w in (d if isinstance(d, list) else [d])]
    if not weights or None in weights:
        return None
    return tuple(w for w in weights if w is not None)


def _weight_of(d: object) -> KnownWeight | None:
    if not isinstance(d, dict):
        return None
    slot, kg, pct = (d.get(k) for k in ("slot", "kg", "uncertainty_pct"))
    if (isinstance(slot, str) and isinstance(kg, int | float) and isinstance(pct, int | float)
            and math.isfinite(kg) and math.isfinite(pct)):
        return KnownWeight(float(kg), slot, float(pct))
    return None


def hold_from_record(d: dict[str, object], source: str) -> tuple[int, tuple[Load, ...]]:
    """Which hold and the series from :func:`hold_record`'s dict (or a one-weight
    calibration's recording from before series: its hold "before" or "after" and its
    weight); DataError naming ``source`` when it is not one. A band calibration's first
    hold has no series yet."""
    which = d.get("hold")
    if which in _OLD_HOLDS:
        weight = _weight_of(d)
        if weight is not None:
            return _OLD_HOLDS.index(str(which)), ((weight,),)
    elif isinstance(which, int) and not isinstance(which, bool) and isinstance(
            d.get("weights"), list):
        series = [_load_of(w) for w in d["weights"]]  # type: ignore[attr-defined]
        if which == 0 and not series and d.get("band") is True:
            return 0, ()
        if series and 0 <= which <= len(series) and all(w is not None for w in series):
            return which, tuple(w for w in series if w is not None)
    raise DataError(f"{source}: the recorded calibration hold is malformed ({d!r})")


async def _level_hold(open_link: Callable[[], Awaitable[Link]], profile: Profile,
                      presenters: Sequence[Presenter[Never, HoldSamples]], wall_clock: bool,
                      what: str, recorder: Recorder | None, hold_s: float | None
                      ) -> HoldSamples:
    """One level hold of ``hold_s`` (:func:`level_hold_procedure`) on the link opened
    again; EstimationError naming ``what`` when it does not end with a steady hold."""
    link = await open_link()
    session: Session[Never, HoldSamples] = Session(
        link, profile, recorder=recorder, presenters=presenters,
        procedure=level_hold_procedure(profile, confirmed=True, hold_s=hold_s),
        wall_clock=wall_clock)
    result = await session.run()
    if result.phase is not Phase.DONE or result.verification is None:
        raise EstimationError(f"{what}: {result.reason}")
    return result.verification


def _change(profile: Profile, weight: KnownWeight, count: int) -> PieceChange:
    """``count`` (±1) of the known ``weight`` at its slot."""
    return PieceChange(profile.slot(weight.slot).name, f"{weight.kg:g} kg", count,
                       weight.kg * profile.gravity_m_s2, weight.uncertainty_pct)


def _load_text(load: Load, profile: Profile) -> str:
    return " + ".join(f"{w.kg:g} kg at {profile.slot(w.slot).name}" for w in load)


def calibration_experiment(before: HoldSamples, after: HoldSamples, profile: Profile,
                           hung: Load, removed: Load | None = None) -> Experiment:
    """The experiment of the level holds ``before`` and ``after``, between which
    ``removed`` was taken off (None: nothing) and ``hung`` hung."""
    change = tuple(_change(profile, w, -1) for w in removed or ()) + tuple(
        _change(profile, w, 1) for w in hung)
    fit = estimate_segment(before, profile)
    q_cov = fit.q_cov.copy()
    q_cov[3, 3] += _M_Z_STD**2
    q_after = fit.q + ballast_change(profile, change)[0]
    moved = f"{_load_text(removed, profile)} → " if removed else ""
    return Experiment(f"calibrate {moved}{_load_text(hung, profile)}",
                      calibration_hold(before, profile, fit.q),
                      calibration_hold(after, profile, q_after), change, fit.q, q_cov)


def check_against_profile(experiments: Sequence[Experiment], profile: Profile,
                          stopped: str = "") -> CalibrationRun:
    """``experiments`` checked in order against the profile's own thrust map (its
    calibration, else the prior) and each other, stored nowhere."""
    post, outcomes = profile.thrust_map or prior(profile), []
    for exp in experiments:
        post, outcome = update(post, exp, profile)
        outcomes.append(outcome)
    return CalibrationRun(tuple(experiments), tuple(outcomes), post, profile, stopped)


def swap_text(hung: Load, removed: Load | None, profile: Profile) -> str:
    """What the operator does before the next hold: take ``removed`` off, hang ``hung``."""
    def what(load: Load) -> str:
        return " and ".join((f"{w.kg:g} kg (its weight in water)" if w.kg > 0
                             else f"the float of {-w.kg:g} kgf lift")
                            + f" at slot {profile.slot(w.slot).name}" for w in load)
    off = f"take {what(removed)} off; " if removed else ""
    return f"{off}hang {what(hung)}, clear of the thrusters, then confirm"


async def calibrate_with_weights(open_link: Callable[[], Awaitable[Link]], profile: Profile,
                                 weights: Sequence[Load], hung: Callable[[str, Load], bool],
                                 *, db: Path | None, vehicle: str,
                                 presenters: Sequence[Presenter[Never, HoldSamples]] | None
                                 = None, wall_clock: bool = True,
                                 record: Callable[[dict[str, object]], Recorder | None]
                                 | None = None, hold_s: float | None = None,
                                 band_pct: float | None = None) -> CalibrationRun:
    """A level hold, then per load of ``weights``: ``hung(text, load)`` (the operator takes
    the previous load off, hangs this one and says so), a level hold, and the experiment
    of the two holds checked against the calibration so far, ``profile``'s thrust map
    (the vehicle's stored calibration: :func:`~trimd.app.history.calibration.
    calibrated_profile`; none: the prior), and stored under ``vehicle`` in the history
    ``db`` (None: not stored) as soon as it is made.
    With ``band_pct`` (the loads' 1σ [%]) and no ``weights``, a band calibration: its two
    loads are :func:`~trimd.ballast.band.band_load` of the first hold's W − B and net
    moments, upward then downward (module docstring).
    ``hung`` False before the first load aborts with UsageError; later it stops the
    series with the experiments made so far (said in :attr:`CalibrationRun.stopped`).
    ``record`` gives each hold's recorder from what its recording says of it
    (:func:`hold_record`; None: not recorded). Each hold collects for ``hold_s`` [s]
    (None: the profile's ``collect_max_s``): longer holds make each experiment's noise
    smaller, and its check against the calibration so far sharper (docs/method.md §7).
    ProfileError for a slot the profile does not have; UsageError for a weight of 0 kg,
    a hold shorter than :data:`MIN_HOLD_S` or a band load the slots cannot take;
    LinkError, EstimationError when a hold fails."""
    checked_hold_s(hold_s)
    for w in (w for load in weights for w in load):
        slot = profile.slot(w.slot)
        if not (math.isfinite(w.kg) and w.kg != 0):
            raise UsageError(f"--mass {w.kg:g}@{slot.name}: a weight of 0 kg calibrates "
                             "nothing", "trimd calibrate")
    if not weights and band_pct is None:
        raise UsageError("no weight to calibrate with: give --mass KG@SLOT", "trimd calibrate")
    shown = list(presenters or [])
    band = band_pct is not None

    def level_hold(k: int) -> Awaitable[HoldSamples]:
        return _level_hold(open_link, profile, shown, wall_clock, f"level hold {k + 1}",
                           record(hold_record(k, weights, hold_s, band)) if record else None,
                           hold_s)

    post = profile.thrust_map or prior(profile)
    holds = [await level_hold(0)]
    texts: Sequence[str] = [""] * len(weights)
    if band_pct is not None and not weights:
        weights, texts = _band_series(holds[0], profile, band_pct)
    experiments: list[Experiment] = []
    outcomes: list[Outcome] = []
    for k, load in enumerate(weights):
        removed = weights[k - 1] if k else None
        if not hung(texts[k] + swap_text(load, removed, profile), load):
            if not k:
                raise UsageError("calibration aborted: the weight was not hung",
                                 "trimd calibrate")
            return CalibrationRun(tuple(experiments), tuple(outcomes), post, profile,
                                  f"stopped by the operator after {k} of {len(weights)} "
                                  "weights")
        holds.append(await level_hold(k + 1))
        exp = calibration_experiment(holds[-2], holds[-1], profile, load, removed)
        if db is None:
            post, outcome = update(post, exp, profile)
        else:  # a rejected experiment leaves the calibration as it was
            with History(db) as history:
                post, outcome = store_experiment(history, vehicle, profile, exp, post)
        experiments.append(exp)
        outcomes.append(outcome)
    return CalibrationRun(tuple(experiments), tuple(outcomes), post, profile)


def _band_series(first: HoldSamples, profile: Profile, uncertainty_pct: float
                 ) -> tuple[tuple[Load, ...], tuple[str, ...]]:
    """The band calibration's series, chosen from the ``first`` hold's W − B and x, y net
    moments (with the profile's calibration): the load for the upper edges, then the one
    for the lower edges (either left out when the vehicle is there already: a load of
    less than a gram); and what each is for, for the operator."""
    fit = estimate_segment(first, profile)
    q_sd = [math.sqrt(fit.q_cov[k, k]) for k in range(3)]
    sd = q_sd[0]
    g = profile.gravity_m_s2
    loads: list[Load] = []
    texts: list[str] = []
    for upward in (True, False):
        load = band_load(profile, fit.q[:3], upward, q_sd)
        side, state = ("upper", "heavy") if upward else ("lower", "buoyant")
        text = (
            f"the vehicle held level at W − B {fit.q[0]:+.2f} ± {sd:.2f} N, x, y net moments "
            f"{fit.q[1]:+.2f} ± {q_sd[1]:.2f}, {fit.q[2]:+.2f} ± {q_sd[2]:.2f} N·m; for each "
            "vertical thruster to hunt at "
            f"its {side} band edge it should be {state} at {load.margin_N:+.2f} N, "
            f"{load.aim[1]:+.2f}, {load.aim[2]:+.2f} N·m"
            + (f" (its W − B is known to ± {sd:.2f} N only, more than the band's "
               f"{abs(load.margin_N):.2f} N: the load may miss it; a calibration first, "
               "e.g. the verify hold after `trimd ballast apply`, narrows it)"
               if sd > abs(load.margin_N) else "")
            + (", the load leaving the moments {:+.3f}, {:+.3f} N·m off it".format(
                *load.miss_Nm) if max(map(abs, load.miss_Nm)) > 1e-6 else "") + ": ")
        hung = tuple(KnownWeight(round(f / g, 3), slot, uncertainty_pct)  # to the gram
                     for slot, f in load.pieces if round(f / g, 3))
        if hung:
            loads.append(hung)
            texts.append(text)
    return tuple(loads), tuple(texts)
