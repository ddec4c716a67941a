"""What a deliberate calibration hangs and the experiment each change of it makes
(:mod:`trimd.app.calibrate`): the known weights, the experiment of two level holds with
the change of load between them, what the operator is told to swap, and a series' run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

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
from trimd.core.estimate import HoldSamples
from trimd.core.profile import Profile
from trimd.core.segment import estimate_segment

__all__ = ["CalibrationRun", "KnownWeight", "Load", "calibration_experiment",
           "check_against_profile", "load_change", "swap_text"]


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
    vehicle's calibration after them, the profile they were made with, why the series
    stopped early ("" when it ran to its end) and, of a band calibration, the side of each
    experiment's load (True: the upper edges'; :mod:`trimd.app.calibrate_band`)."""

    experiments: tuple[Experiment, ...]
    outcomes: tuple[Outcome, ...]
    posterior: ThrustMapPosterior
    profile: Profile
    stopped: str = ""
    sides: tuple[bool, ...] = ()


def load_change(profile: Profile, load: Load, count: int = 1) -> tuple[PieceChange, ...]:
    """``count`` (±1) of each known weight of ``load`` at its slot."""
    return tuple(PieceChange(profile.slot(w.slot).name, f"{w.kg:g} kg", count,
                             w.kg * profile.gravity_m_s2, w.uncertainty_pct) for w in load)


def _load_text(load: Load, profile: Profile) -> str:
    return " + ".join(f"{w.kg:g} kg at {profile.slot(w.slot).name}" for w in load)


def calibration_experiment(before: HoldSamples, after: HoldSamples, profile: Profile,
                           hung: Load, removed: Load | None = None) -> Experiment:
    """The experiment of the level holds ``before`` and ``after``, between which
    ``removed`` was taken off (None: nothing) and ``hung`` hung."""
    change = load_change(profile, removed or (), -1) + load_change(profile, hung)
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
