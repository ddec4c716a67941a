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
calibration (``trimd calibrate --band``, for a trimmed vehicle) chooses its loads from
the holds as it goes (:mod:`trimd.app.calibrate_band`): the load that makes the vehicle
just heavy enough for its vertical thrusters to hunt at the upper edges of their bands
(:mod:`trimd.ballast.band`), which the next hold then shows, aimed again while a hold
misses a thruster's edge, then the same for the lower edges, just buoyant enough. What a
calibration hangs and the experiment each change makes: :mod:`trimd.app.calibration_loads`.

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
from dataclasses import replace
from pathlib import Path
from typing import Never

from trimd.app.calibrate_band import BAND_TRIES, band_series
from trimd.app.calibration_loads import (
    CalibrationRun,
    KnownWeight,
    Load,
    calibration_experiment,
    swap_text,
)
from trimd.app.history import History
from trimd.app.history.calibration import store_experiment
from trimd.app.session import Presenter, Recorder, Session
from trimd.core.calibration import Experiment, Outcome, ThrustMapPosterior, prior, update
from trimd.core.errors import DataError, EstimationError, UsageError
from trimd.core.estimate import HoldSamples
from trimd.core.events import Phase
from trimd.core.link import Link
from trimd.core.procedure import Procedure
from trimd.core.profile import Profile

__all__ = ["LIGHT_SHARE", "MIN_HOLD_S", "calibrate_with_weights", "checked_hold_s",
           "hold_from_record", "hold_record", "level_hold_procedure", "light_weight_advice",
           "recorded_hold_s", "recorded_sides"]

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
                band: bool = False, sides: Sequence[bool] = ()) -> dict[str, object]:
    """What a calibration hold's recording says of itself: which hold of the series it is
    (0: before any weight), the series' loads in order (one weight as its dict, several
    as a list of them; a band calibration's first hold, made before its load is chosen:
    none), whether it is a band calibration, the side of each band load so far (True: the
    upper edges') and, when the operator chose it, how long each hold collects [s]."""
    return {"hold": index, "weights": [_weight_dict(load[0]) if len(load) == 1 else
                                       [_weight_dict(w) for w in load] for load in series],
            **({"band": True} if band else {}),
            **({"sides": list(sides)} if sides else {}),
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


def recorded_sides(d: dict[str, object], loads: int, source: str) -> tuple[bool, ...]:
    """The side of each of the first ``loads`` band loads from :func:`hold_record`'s dict
    (True: the upper edges'); () when it does not say (not a band calibration, or recorded
    before 2026-11-30). DataError naming ``source`` when it says something else."""
    value = d.get("sides")
    if value is None:
        return ()
    if not (isinstance(value, list) and len(value) >= loads
            and all(isinstance(v, bool) for v in value)):
        raise DataError(f"{source}: the recorded band loads' sides are malformed ({value!r}; "
                        f"one true or false per load, {loads} loads)")
    return tuple(value[:loads])


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



async def calibrate_with_weights(open_link: Callable[[], Awaitable[Link]], profile: Profile,
                                 weights: Sequence[Load], hung: Callable[[str, Load], bool],
                                 *, db: Path | None, vehicle: str,
                                 presenters: Sequence[Presenter[Never, HoldSamples]] | None
                                 = None, wall_clock: bool = True,
                                 record: Callable[[dict[str, object]], Recorder | None]
                                 | None = None, hold_s: float | None = None,
                                 band_pct: float | None = None, band_tries: int = BAND_TRIES
                                 ) -> CalibrationRun:
    """A level hold, then per load of ``weights``: ``hung(text, load)`` (the operator takes
    the previous load off, hangs this one and says so), a level hold, and the experiment
    of the two holds checked against the calibration so far, ``profile``'s thrust map
    (the vehicle's stored calibration: :func:`~trimd.app.history.calibration.
    calibrated_profile`; none: the prior), and stored under ``vehicle`` in the history
    ``db`` (None: not stored) as soon as it is made.
    With ``band_pct`` (the loads' 1σ [%]) and no ``weights``, a band calibration
    (:func:`~trimd.app.calibrate_band.band_series`, at most ``band_tries`` holds per
    side): its loads chosen from the holds as it goes (module docstring).
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

    def level_hold(k: int, series: tuple[Load, ...], sides: tuple[bool, ...] = ()
                   ) -> Awaitable[HoldSamples]:
        return _level_hold(open_link, profile, shown, wall_clock, f"level hold {k + 1}",
                           record(hold_record(k, series, hold_s, band, sides)) if record
                           else None, hold_s)

    def learn(exp: Experiment, post: ThrustMapPosterior
              ) -> tuple[ThrustMapPosterior, Outcome]:
        if db is None:
            return update(post, exp, profile)
        with History(db) as history:     # a rejected experiment leaves the calibration
            return store_experiment(history, vehicle, profile, exp, post)

    post = profile.thrust_map or prior(profile)
    if band_pct is not None and not weights:
        return await band_series(level_hold, learn, hung, profile, post, band_pct, band_tries)
    series = tuple(weights)
    holds = [await level_hold(0, series)]
    experiments: list[Experiment] = []
    outcomes: list[Outcome] = []
    for k, load in enumerate(series):
        removed = series[k - 1] if k else None
        if not hung(swap_text(load, removed, profile), load):
            if not k:
                raise UsageError("calibration aborted: the weight was not hung",
                                 "trimd calibrate")
            return CalibrationRun(tuple(experiments), tuple(outcomes), post, profile,
                                  f"stopped by the operator after {k} of {len(series)} "
                                  "weights")
        holds.append(await level_hold(k + 1, series))
        exp = calibration_experiment(holds[-2], holds[-1], profile, load, removed)
        post, outcome = learn(exp, post)
        experiments.append(exp)
        outcomes.append(outcome)
    return CalibrationRun(tuple(experiments), tuple(outcomes), post, profile)
