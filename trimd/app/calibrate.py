"""A deliberate calibration of the thrust map (``trimd calibrate``, docs/method.md §7): a
level hold, the operator hangs a known weight at a known ballast slot, a second level
hold. The two holds and the weight are one calibration experiment, checked against the
vehicle's calibration so far and stored in its trim history like those of
``ballast apply`` and a verify hold (:mod:`trimd.app.history.calibration`).

Each hold is a session of its own on the link opened again (the verify hold's
procedure: the profile's first hold, level), so the vehicle is released while the weight
is hung, and a recording of its own that says which hold it is and what weight was hung:
:func:`trimd.app.replay.replay_calibration` reproduces the experiment and its outcome from
the two. Each collects for the profile's whole ``collect_max_s``, not until the trim's
stop rule is met: that rule stops once the noise is below the thrust map's share of the
±, while the experiment's noise is what it cannot tell from the thrust map's errors (on
the simulated Sabertooth a level hold's mean Z ± 2.6–18 N after 10 s, ≈ 0.9 N after
180 s). Confirmation is the caller's: both holds command the vehicle without asking again.
"""

from __future__ import annotations

import math
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Never

from trimd.app.history import History
from trimd.app.history.calibration import store_experiment
from trimd.app.session import Presenter, Recorder, Session
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

__all__ = ["HOLDS", "CalibrationRun", "KnownWeight", "calibrate_with_weight",
           "calibration_experiment", "check_against_profile", "hold_from_record", "hold_record",
           "level_hold_procedure"]

#: The two level holds of a calibration, in order, as their recordings name them.
HOLDS = ("before", "after")
#: 1σ of the height of the centre of gravity's net moment [N·m] assumed for the level
#: fit's q, which enters only through the two holds' small difference in attitude.
_M_Z_STD = 1.0


@dataclass(frozen=True)
class KnownWeight:
    """A weight hung for a calibration: its net downward force in water as ``kg``
    [kgf], at ballast slot ``slot``, known to ``uncertainty_pct`` [%, 1σ]."""

    kg: float
    slot: str
    uncertainty_pct: float = 1.0


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """A deliberate calibration's experiment, what became of it, the vehicle's
    calibration after it, and the profile it was made with."""

    experiment: Experiment
    outcome: Outcome
    posterior: ThrustMapPosterior
    profile: Profile


def level_hold_procedure(profile: Profile, *, confirmed: bool) -> Procedure[Never, HoldSamples]:
    """A calibration's level hold: the verify hold's procedure (the profile's first hold,
    level) collected for the profile's whole ``collect_max_s`` (module docstring), whose
    result is the hold's samples."""
    return Procedure(profile, confirmed=confirmed, verify=_the_hold,
                     collect_s=profile.procedure.collect_max_s)


def _the_hold(hold: HoldSamples) -> HoldSamples:
    return hold


def hold_record(which: str, weight: KnownWeight) -> dict[str, object]:
    """What a calibration hold's recording says of itself (``which`` of :data:`HOLDS`)."""
    return {"hold": which, "kg": weight.kg, "slot": weight.slot,
            "uncertainty_pct": weight.uncertainty_pct}


def hold_from_record(d: dict[str, object], source: str) -> tuple[str, KnownWeight]:
    """Which hold and the weight from :func:`hold_record`'s dict; DataError naming
    ``source`` when it is not one."""
    which, slot, kg, pct = (d.get(k) for k in ("hold", "slot", "kg", "uncertainty_pct"))
    if (which in HOLDS and isinstance(slot, str) and isinstance(kg, int | float)
            and isinstance(pct, int | float) and math.isfinite(kg) and math.isfinite(pct)):
        return str(which), KnownWeight(float(kg), slot, float(pct))
    raise DataError(f"{source}: the recorded calibration hold is malformed ({d!r})")


async def _level_hold(open_link: Callable[[], Awaitable[Link]], profile: Profile,
                      presenters: Sequence[Presenter[Never, HoldSamples]], wall_clock: bool,
                      what: str,
                      recorder: Recorder | None) -> HoldSamples:
    """One level hold on the link opened again; EstimationError naming ``what`` when it
    does not end with a steady hold."""
    link = await open_link()
    session: Session[Never, HoldSamples] = Session(
        link, profile, recorder=recorder, presenters=presenters,
        procedure=level_hold_procedure(profile, confirmed=True), wall_clock=wall_clock)
    result = await session.run()
    if result.phase is not Phase.DONE or result.verification is None:
        raise EstimationError(f"{what}: {result.reason}")
    return result.verification


def calibration_experiment(before: HoldSamples, after: HoldSamples, profile: Profile,
                           weight: KnownWeight) -> Experiment:
    """The experiment of the level holds ``before`` and ``after`` hanging ``weight``."""
    slot = profile.slot(weight.slot)
    change = (PieceChange(slot.name, f"{weight.kg:g} kg", 1, weight.kg * profile.gravity_m_s2,
                          weight.uncertainty_pct),)
    fit = estimate_segment(before, profile)
    q_cov = fit.q_cov.copy()
    q_cov[3, 3] += _M_Z_STD**2
    q_after = fit.q + ballast_change(profile, change)[0]
    return Experiment(f"calibrate {weight.kg:g} kg at {slot.name}",
                      calibration_hold(before, profile, fit.q),
                      calibration_hold(after, profile, q_after), change, fit.q, q_cov)


def check_against_profile(exp: Experiment, profile: Profile) -> CalibrationRun:
    """``exp`` checked against the profile's own thrust map (its calibration, else the
    prior), stored nowhere."""
    post, outcome = update(profile.thrust_map or prior(profile), exp, profile)
    return CalibrationRun(exp, outcome, post, profile)


async def calibrate_with_weight(open_link: Callable[[], Awaitable[Link]], profile: Profile,
                                weight: KnownWeight, hung: Callable[[str], bool], *,
                                db: Path | None, vehicle: str,
                                presenters: Sequence[Presenter[Never, HoldSamples]] | None = None,
                                wall_clock: bool = True,
                                record: Callable[[dict[str, object]], Recorder | None]
                                | None = None) -> CalibrationRun:
    """The level hold, ``hung(text)`` (the operator hangs the weight and says so: False
    aborts with UsageError), the second level hold, and the experiment checked and stored
    under ``vehicle`` in the history ``db`` (None: checked against the profile's own
    thrust map, and not stored). ``record`` gives each hold's recorder from what the
    recording says of it (:func:`hold_record`; None: not recorded). ProfileError for a slot
    the profile does not have; LinkError, EstimationError when a hold fails."""
    slot = profile.slot(weight.slot)
    if not (math.isfinite(weight.kg) and weight.kg != 0):
        raise UsageError(f"--mass {weight.kg:g}@{slot.name}: a weight of 0 kg calibrates "
                         "nothing", "trimd calibrate")
    shown = list(presenters or [])

    def recorder(which: str) -> Recorder | None:
        return record(hold_record(which, weight)) if record else None

    before = await _level_hold(open_link, profile, shown, wall_clock, "the first level hold",
                               recorder(HOLDS[0]))
    if not hung(f"hang {weight.kg:g} kg (its weight in water) at slot {slot.name}, clear of "
                "the thrusters, then confirm"):
        raise UsageError("calibration aborted: the weight was not hung", "trimd calibrate")
    after = await _level_hold(open_link, profile, shown, wall_clock, "the second level hold",
                              recorder(HOLDS[1]))
    exp = calibration_experiment(before, after, profile, weight)
    if db is None:
        return check_against_profile(exp, profile)
    with History(db) as history:  # a rejected experiment leaves the calibration as it was
        post, outcome = store_experiment(history, vehicle, profile, exp)
    return CalibrationRun(exp, outcome, post, profile)
