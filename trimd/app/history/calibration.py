"""The vehicle's thrust-map calibration in the trim history (docs/method.md §7).

Every trim's and verify hold's level hold is stored summarised
(:func:`trimd.core.calibration.calibration_hold`) with the vehicle's net quantities and
the ballast installed then. A verify hold after a ballast change recorded since the
previous level hold (``trimd ballast apply``) makes the two a calibration experiment:
checked against what the earlier experiments taught, then stored, accepted or rejected
and why. A trim is never the second hold of an experiment: between two trims the vehicle
may have changed in ways nobody recorded (new equipment), while a verify hold checks
exactly the ballast installed since.

The calibration is recomputed from the stored experiments of the vehicle's profile, in
order (:func:`trimd.core.calibration.calibrate`), and every later trim, verify hold and
correction of the vehicle uses it (:func:`calibrated_profile`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from trimd.app.history.store import History
from trimd.app.results import AnyResult
from trimd.ballast.verify import Verification
from trimd.core.calibration import (
    Calibration,
    Experiment,
    FloatReference,
    Outcome,
    ThrustMapPosterior,
    calibrate,
    calibration_hold,
    installed_change,
    update,
)
from trimd.core.calibration_json import (
    experiment_from_dict,
    experiment_to_dict,
    hold_from_dict,
    hold_to_dict,
)
from trimd.core.float_reference import float_reference
from trimd.core.floating import FloatResult
from trimd.core.learnt import band_edge_to_dict, band_edges, gain_to_dict, gains
from trimd.core.profile import InstalledPiece, Profile

__all__ = ["REFERENCE_WITHIN_S", "calibrated_profile", "record_float_reference",
           "record_level_hold", "store_experiment", "stored_calibration"]

#: A float check this soon [s] after the vehicle's last level hold, with no ballast change
#: recorded between, is taken to float the vehicle of that hold (the same dive): a float
#: reference (:mod:`trimd.core.float_reference`).
REFERENCE_WITHIN_S = 1800.0


def stored_calibration(history: History, vehicle: str, profile: Profile) -> Calibration:
    """The vehicle's calibration recomputed from its stored experiments with ``profile``
    (those recorded with another profile left out). DataError for a malformed record."""
    experiments = [experiment_from_dict(r.values["experiment"],
                                        f"{history.path}: calibration experiment {r.id}")
                   for r in history.experiments(vehicle)
                   if r.values.get("profile") == profile.name]
    return calibrate(experiments, profile)


def calibrated_profile(db: str | Path | None, vehicle: str, profile: Profile) -> Profile:
    """``profile`` with the vehicle's calibration as its ``thrust_map`` when the history
    ``db`` holds an accepted experiment for it; else ``profile`` itself (bit for bit the
    uncalibrated estimate). The file is not created for reading."""
    if db is None or not Path(db).exists():
        return profile
    with History(db) as history:
        cal = stored_calibration(history, vehicle, profile)
    return profile if cal.posterior.experiments == 0 else replace(profile,
                                                                   thrust_map=cal.posterior)


def _installed(stored: Sequence[dict[str, Any]]) -> list[InstalledPiece]:
    """A stored configuration's pieces."""
    return [InstalledPiece(str(p["slot"]), str(p["piece"]), int(p["count"])) for p in stored]


def store_experiment(history: History, vehicle: str, profile: Profile,
                     exp: Experiment | FloatReference,
                     before: ThrustMapPosterior | None = None, t_unix: float | None = None
                     ) -> tuple[ThrustMapPosterior, Outcome]:
    """Check ``exp`` against the vehicle's calibration so far (``before``; None: as stored),
    store it with what became of it (and the gains after it), and return the calibration
    after it and the outcome."""
    if before is None:
        before = stored_calibration(history, vehicle, profile).posterior
    after, outcome = update(before, exp, profile)
    history.record_experiment(vehicle, time.time() if t_unix is None else t_unix, {
        "profile": profile.name, "experiment": experiment_to_dict(exp),
        "accepted": outcome.accepted, "message": outcome.message,
        "chi2": outcome.chi2, "sigma": outcome.sigma,
        "calibration": {"experiments": after.experiments,
                        "gains": [gain_to_dict(g) for g in gains(after, profile)],
                        "band_edges": [band_edge_to_dict(b)
                                       for b in band_edges(after, profile)]}})
    return after, outcome


def record_level_hold(history: History, vehicle: str, profile: Profile,
                      result: AnyResult, record_id: int,
                      installed: Sequence[InstalledPiece], t_unix: float | None = None
                      ) -> Outcome | None:
    """Store ``result``'s level hold (its trim's or verify hold's record ``record_id``,
    ``installed`` the ballast on the vehicle during it) and, for a verify hold after a
    ballast change, the calibration experiment it makes with the previous level hold;
    what became of the experiment, None when there was none."""
    hold, v = result.level_hold, result.verification
    if hold is None or hold.thrust is None:
        return None
    if isinstance(v, Verification):
        source, q, q_cov = "verify", v.measured.q, v.measured.q_cov
    elif result.estimate is not None:
        source, q, q_cov = "trim", result.estimate.q, result.estimate.q_cov
    else:
        return None
    t = time.time() if t_unix is None else t_unix
    summary = calibration_hold(hold, profile, q)
    previous = [r for r in history.level_holds(vehicle) if r.values["profile"] == profile.name]
    outcome = None
    if source == "verify" and previous:
        last = previous[-1].values
        change = installed_change(_installed(last["installed"]), installed)
        if change:
            where = f"{history.path}: level hold {previous[-1].id}"
            exp = Experiment(f"{last['source']} {last['record_id']} → {source} {record_id}",
                             hold_from_dict(last["hold"], where), summary, change,
                             np.asarray(last["q_N_Nm"], float), np.asarray(last["q_cov"], float))
            outcome = store_experiment(history, vehicle, profile, exp, t_unix=t)[1]
    history.record_level_hold(vehicle, t, {
        "profile": profile.name, "source": source, "record_id": record_id,
        "hold": hold_to_dict(summary), "q_N_Nm": q.tolist(), "q_cov": q_cov.tolist(),
        "installed": [{"slot": p.slot, "piece": p.piece, "count": p.count}
                      for p in installed]})
    return outcome


def record_float_reference(history: History, vehicle: str, profile: Profile, f: FloatResult,
                           record_id: int, installed: Sequence[InstalledPiece],
                           t_unix: float | None = None) -> Outcome | None:
    """For the float check ``f`` (record ``record_id``, ``installed`` the ballast on the
    vehicle) within :data:`REFERENCE_WITHIN_S` of the vehicle's last level hold, with no
    ballast change recorded since, the float reference the two make (q_z the hold's
    stored estimate): checked, stored, what became of it; None when there is none."""
    t = time.time() if t_unix is None else t_unix
    previous = [r for r in history.level_holds(vehicle) if r.values["profile"] == profile.name]
    if not previous or t - previous[-1].t_unix > REFERENCE_WITHIN_S:
        return None
    last = previous[-1].values
    if installed_change(_installed(last["installed"]), installed):
        return None
    where = f"{history.path}: level hold {previous[-1].id}"
    ref = float_reference(f"{last['source']} {last['record_id']} → float {record_id}",
                          hold_from_dict(last["hold"], where), f, float(last["q_N_Nm"][3]),
                          float(np.asarray(last["q_cov"], float)[3, 3]))
    return store_experiment(history, vehicle, profile, ref, t_unix=t)[1]
