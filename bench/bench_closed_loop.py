"""The closed loop (issue 24): trim → apply → check → at most one correction → apply →
check, on simulated vehicles that their profiles do not describe exactly, judged by the
TRUE vehicle. The check is a verify hold (``verify``: the thrusters hold the vehicle level
and the thrust map reads what the ballast left) or a float check (``float``: the
thrusters at neutral, the attitude the vehicle floats at, no thrust map).

Per seed and case (:data:`bench.bench_sim_coverage.CASES`: the BlueROV2 Heavy with a payload
at a slot and with a small payload, the Sabertooth with 10 kg at AftSB): the full trim
(:func:`tests.helpers.sim_trim`); then per check, from that same trim, its loop: the
trim's ``milp`` proposal recorded as installed (:func:`trimd.app.apply.apply_ballast`, in
a history of the loop's own) and fitted on the simulated vehicle (its pieces as payload
items at their slots: the sim's ballast changes); the check on the same seed (the same
true vehicle): a verify hold (:func:`tests.helpers.sim_verify`) or a float check
(:func:`tests.helpers.sim_float`, in the depth envelope of
:data:`bench.bench_float.WIDE_ENVELOPE_M`, wider than the profiles': the simulator has no
bottom; as ``trimd float --correct`` runs it, collecting to the end unless it floats
level); when it asks for one, the correction against the ballast installed now —
from the verify hold when :func:`trimd.ballast.correct.needs_correction` (NOT level, or
NOT as predicted: :func:`~trimd.ballast.correct.propose_correction`), from the float when
its verdict is not "level" (:func:`~trimd.ballast.correct.propose_float_correction`) —
recorded and fitted whether or not it is ``feasible`` (the best achievable, as a trim's
proposal), and a second check of it. The loop stops there, whatever that check says.

Judged by the simulator's truth (:func:`trimd.drivers.sim.truth.passive_trim_deg` of the
true vehicle with every piece fitted so far, thrusters off; roll and pitch [deg]): the
share of seeds within the profile's level tolerance on both axes after one trim and after
the loop, the worst and RMS |roll| and |pitch|, how many needed a correction (and why: NOT
level, undecided, NOT as predicted), how often each check's verdict was right, wrong or
undecided about the true vehicle, and the loop's diving time (simulated: every session
from its start) beside a trim followed by a second full trim of the ballasted vehicle (its
two holds, one tilted: what the operator does without the loop), timed on the first
``TRIMD_LOOP_SECOND_TRIMS`` seeds. Seeds whose trim or a check did not end with a result
(a float released at its depth envelope before the attitude had settled …) count as
outside the tolerance (the loop did not deliver) and are listed with the reason.

``TRIMD_LOOP_SEEDS`` (default 200) seeds per case; ``TRIMD_LOOP_CHECK`` the checks, comma
separated (default ``verify,float``: both loops from each trim); ``TRIMD_LOOP_OPTIONS`` the
sim options (default ``disturb=real,truth=perturbed,thrust_err_max=0.1``: realistic
disturbances, thrust curves 5–10 % off, ESC dead bands up to 4 µs off with outputs hunting
at their edge); ``TRIMD_LOOP_SECOND_TRIMS`` (default 20); ``TRIMD_LOOP_CASES``
comma-separated words picking cases; ``TRIMD_COVERAGE_PROCESSES`` (default 1) worker
processes. One seed takes ≈ 5 s (Heavy) and ≈ 10 s (Sabertooth) of one core per loop,
plus a trim's for a second trim.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.bench_float import WIDE_ENVELOPE_M
from bench.bench_sim_coverage import CASES, picked, run_seeds, seeding
from bench.size import size, sized_profile
from tests.helpers import carried, sim_float, sim_trim, sim_verify
from trimd.app.apply import apply_ballast
from trimd.ballast.check import SlotLoad
from trimd.ballast.correct import (
    Correction,
    needs_correction,
    propose_correction,
    propose_float_correction,
)
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import Verification
from trimd.core.errors import DataError, ProfileError
from trimd.core.estimate import StaticEstimate
from trimd.core.events import Phase
from trimd.core.floating import Verdict
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.truth import passive_trim_deg
from trimd.drivers.sim.vehicle import SimVehicle

OPTIONS = "disturb=real,truth=perturbed,thrust_err_max=0.1"
#: What each check is called in the report.
CHECK_NAMES = {"verify": "verify hold", "float": "float"}


@dataclass(frozen=True)
class Hold:
    """One check of the loop (a verify hold or a float): its verdict (``level`` None:
    undecided; ``as_predicted``: a verify hold's, a float's always True), the TRUE
    vehicle's passive roll and pitch [deg] while it was checked (the ballast fitted then),
    the simulated time the check's session took [s]."""

    level: bool | None
    as_predicted: bool
    true_deg: tuple[float, float]
    sim_s: float

    @property
    def verdict(self) -> str:
        """The verdict in words."""
        said = {True: "level", False: "NOT level", None: "undecided"}[self.level]
        return said + ("" if self.as_predicted else " NOT as predicted")


@dataclass(frozen=True)
class Loop:
    """One seed's loop: ``outcome`` "done" or where it stopped; the trim's simulated time
    [s]; the TRUE roll and pitch [deg] with the trim's proposal fitted (``after_trim``)
    and at the end of the loop (``after_loop``); the checks; the correction's
    feasibility and message ("" without one); the simulated time [s] of a second full
    trim of the ballasted vehicle (None: not run, or it did not end DONE)."""

    seed: int
    outcome: str
    trim_s: float
    after_trim: tuple[float, float] | None = None
    after_loop: tuple[float, float] | None = None
    holds: tuple[Hold, ...] = ()
    correction_feasible: bool | None = None
    correction: str = ""
    second_trim_s: float | None = None

    @property
    def corrected(self) -> bool:
        """A correction was proposed and fitted."""
        return len(self.holds) > 1


@dataclass(frozen=True)
class Trial:
    """What each check of one seed's loop needs: the simulated vehicle's profile, hidden
    payload, seed and sim options; the trim's TRUE vehicle and its estimate."""

    profile: Profile
    payload: str
    seed: int
    options: str
    vehicle: SimVehicle
    estimate: StaticEstimate


@dataclass(frozen=True)
class Checked:
    """A check's outcome: the hold (None: the check gave no result, ``reason`` says why)
    and, when it asks for one, the correction of the ballast installed now (a function of
    that ballast)."""

    hold: Hold | None
    reason: str = ""
    correct: Callable[[tuple[InstalledPiece, ...]], Correction] | None = None


#: A check of the loop: (trial, the estimate the ballast since was proposed for, the pieces
#: installed since it, every piece fitted since the trim) → its outcome.
Check = Callable[[Trial, StaticEstimate, tuple[SlotLoad, ...], tuple[SlotLoad, ...]], Checked]


def _true_deg(t: Trial, loads: tuple[SlotLoad, ...]) -> tuple[float, float]:
    """Roll and pitch [deg] at which the TRUE vehicle of ``t`` floats, thrusters off, with
    ``loads`` fitted at their positions."""
    return passive_trim_deg(t.vehicle.ballasted(carried(loads, t.profile.gravity_m_s2)).net)


def verify_check(t: Trial, target: StaticEstimate, since: tuple[SlotLoad, ...],
                 fitted: tuple[SlotLoad, ...]) -> Checked:
    """A verify hold of ``target`` with ``since`` installed, ``fitted`` on the vehicle (its
    verdict undecided when it finds the vehicle level but its 95 % interval reaches past
    the tolerance: :attr:`~trimd.ballast.verify.Verification.undecided`); the correction
    from it when :func:`~trimd.ballast.correct.needs_correction`."""
    hold = sim_verify(t.profile, t.payload, t.seed, t.options, target, since, fitted)
    v = hold.result.verification
    if hold.result.phase is not Phase.DONE or not isinstance(v, Verification):
        return Checked(None, hold.result.reason)
    said = None if v.undecided else v.level       # as the operator is told it
    held = Hold(said, v.as_predicted, _true_deg(t, fitted), hold.t_s)
    if not needs_correction(v):
        return Checked(held)
    return Checked(held, correct=lambda installed: propose_correction(
        v, target, t.profile, installed))


def float_check(t: Trial, target: StaticEstimate, since: tuple[SlotLoad, ...],
                fitted: tuple[SlotLoad, ...]) -> Checked:
    """A float check with ``fitted`` on the vehicle, in the profile's depth envelope of
    :data:`~bench.bench_float.WIDE_ENVELOPE_M`; unless it floats level, the correction
    from the attitude it floated at, with the trim's estimate and every piece fitted
    since (``target`` and ``since`` play no part: the float measures the whole vehicle)."""
    g = t.profile.gravity_m_s2
    f = sim_float(t.profile, "+".join(filter(None, (t.payload, carried(fitted, g)))), t.seed,
                  t.options, WIDE_ENVELOPE_M[t.profile.name], for_correction=True)
    r = f.floated
    if r is None:
        return Checked(None, f.result.reason)
    said = {Verdict.LEVEL: True, Verdict.NOT_LEVEL: False}.get(r.verdict)
    held = Hold(said, True, _true_deg(t, fitted), f.t_s)
    if said:
        return Checked(held)
    return Checked(held, correct=lambda installed: propose_float_correction(
        r, t.estimate, fitted, t.profile, installed))


CHECKS: dict[str, Check] = {"verify": verify_check, "float": float_check}


def _loop(t: Trial, check: Check, proposal: Proposal, trim_s: float,
          second_s: float | None) -> Loop:
    """From the trim of ``t`` and its ``proposal``: apply, ``check``, at most one
    correction and a second ``check`` (module docstring)."""
    holds: list[Hold] = []
    feasible, message = None, ""
    with tempfile.TemporaryDirectory() as tmp:
        db = Path(tmp) / "trimd.db"
        try:
            applied = apply_ballast(db, "bench", t.profile, estimate=t.estimate,
                                    proposal=proposal)
            fitted = applied.loads
            after_trim = _true_deg(t, fitted)
            target = t.estimate
            while True:
                c = check(t, target, applied.loads, fitted)
                if c.hold is None:
                    return Loop(t.seed, f"check {len(holds) + 1}: {c.reason}", trim_s,
                                after_trim, _true_deg(t, fitted), tuple(holds), feasible,
                                message, second_s)
                holds.append(c.hold)
                if len(holds) > 1 or c.correct is None:
                    break
                correction = c.correct(applied.installed)
                feasible = correction.proposal.feasible
                message = correction.proposal.message
                applied = apply_ballast(db, "bench", t.profile, estimate=correction.vehicle,
                                        proposal=correction.proposal)
                target = correction.vehicle
                fitted = fitted + applied.loads
        except (DataError, ProfileError) as exc:
            return Loop(t.seed, f"apply or correction: {exc}", trim_s)
    return Loop(t.seed, "done", trim_s, after_trim, _true_deg(t, fitted), tuple(holds),
                feasible, message, second_s)


def run(name: str, payload: str, seed: int, options: str, second_trim: bool,
        checks: tuple[str, ...] = ("verify",)) -> tuple[Loop, ...]:
    """The trim of ``seed`` and, from it, the loop of each of ``checks`` (module
    docstring), in their order; at the tiny size each hold collects for less
    (:func:`bench.size.sized_profile`)."""
    profile = sized_profile(load_profile(name))
    trial = sim_trim(profile, payload, seed, options)
    estimate, proposal = trial.result.estimate, trial.result.proposal
    trim_s = trial.vehicle.t_s
    if trial.result.phase is not Phase.DONE or estimate is None or not isinstance(
            proposal, Proposal):
        return tuple(Loop(seed, f"trim: {trial.result.reason}", trim_s) for _ in checks)
    second_s = None
    if second_trim:
        fitted = carried(proposal.slots, profile.gravity_m_s2)
        again = sim_trim(profile, f"{payload}+{fitted}", seed, options)
        second_s = again.vehicle.t_s if again.result.phase is Phase.DONE else None
    t = Trial(profile, payload, seed, options, trial.vehicle, estimate)
    return tuple(_loop(t, CHECKS[c], proposal, trim_s, second_s) for c in checks)


def _within(angles: tuple[float, float] | None, tol_deg: float) -> bool:
    return angles is not None and max(abs(angles[0]), abs(angles[1])) <= tol_deg


def _worst(angles: list[tuple[float, float] | None]) -> str:
    """Largest and RMS |roll|, |pitch| [deg] of ``angles``."""
    a = np.abs(np.array([x for x in angles if x is not None]).reshape(-1, 2))
    if not len(a):
        return "—"
    rms = np.sqrt(np.mean(a**2, axis=0))
    return (f"|roll| {a[:, 0].max():.2f}°, |pitch| {a[:, 1].max():.2f}° (rms {rms[0]:.2f}°, "
            f"{rms[1]:.2f}°)")


def _share(flags: list[bool]) -> str:
    return f"{np.mean(flags):.0%} ({sum(flags)}/{len(flags)})" if flags else "— (0)"


def _verdicts(holds: list[Hold], tol_deg: float) -> str:
    """How the verdicts of ``holds`` fared against the TRUE vehicle: right, wrong,
    undecided."""
    right = sum(h.level is not None and h.level == _within(h.true_deg, tol_deg)
                for h in holds)
    undecided = sum(h.level is None for h in holds)
    return f"{right} right, {len(holds) - right - undecided} wrong, {undecided} undecided"


def report(runs: list[Loop], tol_deg: float, what: str) -> list[str]:
    """The figures of ``runs``, whose check is a ``what`` (:data:`CHECK_NAMES`), for
    people (module docstring), one string per line."""
    done = [r for r in runs if r.outcome == "done"]
    first = [r.holds[0] for r in runs if r.holds]
    second = [r.holds[1] for r in runs if len(r.holds) > 1]
    needed = [r for r in runs if r.corrected]
    wrong_level = sum(bool(h.level) and not _within(h.true_deg, tol_deg) for h in first + second)
    lines = [
        f"true vehicle within the level tolerance ({tol_deg:g}°): after one trim "
        f"{_share([_within(r.after_trim, tol_deg) for r in runs])}, after the loop "
        f"{_share([_within(r.after_loop, tol_deg) and r.outcome == 'done' for r in runs])}",
        f"worst after one trim {_worst([r.after_trim for r in runs])}; after the loop "
        f"{_worst([r.after_loop for r in runs])}",
        f"correction needed {_share([r.corrected for r in runs])}: the first {what} said "
        f"NOT level {sum(h.level is False for h in first)}, undecided "
        f"{sum(h.level is None for h in first)}, NOT as predicted "
        f"{sum(not h.as_predicted for h in first)}; correction not feasible "
        f"{sum(r.correction_feasible is False for r in needed)}",
        f"verdicts about the true vehicle: first {what} {_verdicts(first, tol_deg)}; after "
        f"the correction {_verdicts(second, tol_deg)}; said level while the true vehicle "
        f"was not: {wrong_level}"]
    loop_s = [r.trim_s + sum(h.sim_s for h in r.holds) for r in done]
    timed = [r for r in done if r.second_trim_s is not None]
    if loop_s:
        check_s = [h.sim_s for h in first + second]
        line = (f"diving time (simulated): loop {np.mean(loop_s):.0f} s mean, "
                f"{np.max(loop_s):.0f} s max (trim {np.mean([r.trim_s for r in done]):.0f} s, "
                f"{what} {np.mean(check_s):.0f} s mean, {np.max(check_s):.0f} s max)")
        if timed:
            both = np.mean([r.trim_s + (r.second_trim_s or 0.0) for r in timed])
            loops = np.mean([r.trim_s + sum(h.sim_s for h in r.holds) for r in timed])
            line += (f"; on {len(timed)} seeds trim + a second full trim {both:.0f} s, "
                     f"their loop {loops:.0f} s ({loops / both:.0%} of it)")
        lines.append(line)
    outside = [r for r in runs if not (_within(r.after_loop, tol_deg) and r.outcome == "done")]
    for r in outside[:size(40, 2)]:
        angles = " → ".join(f"({a[0]:+.2f}°, {a[1]:+.2f}°)" for a in (r.after_trim,
                                                                     r.after_loop) if a)
        verdicts = ", ".join(h.verdict for h in r.holds)
        lines.append(f"  outside: seed {r.seed} {r.outcome[:200]}: true {angles}; {what} "
                     f"{verdicts or '—'}; {r.correction[:90] or 'no correction'}")
    return lines


def main() -> None:
    cfg = seeding("LOOP", size(200, 1), OPTIONS)
    seeds, options = cfg.seeds, cfg.options
    second = int(os.environ.get("TRIMD_LOOP_SECOND_TRIMS", size(20, 1)))
    checks = tuple(os.environ.get("TRIMD_LOOP_CHECK", "verify,float").split(","))
    if unknown := set(checks) - set(CHECKS):
        raise SystemExit(f"TRIMD_LOOP_CHECK: unknown {', '.join(sorted(unknown))} "
                         f"(known: {', '.join(CHECKS)})")
    for name, payload in picked(size(CASES, CASES[:1]), cfg.wanted):
        runs, wall = run_seeds(run, name, payload, seeds, options, cfg.processes,
                               [s < second for s in range(seeds)], [checks] * seeds)
        profile = load_profile(name)
        print(f"{name}, {payload}, sim:{options}: {wall:.1f} s wall per seed "
              f"({', '.join(checks)})")
        for i, check in enumerate(checks):
            loops = [r[i] for r in runs]
            envelope = (f" in a depth envelope of {WIDE_ENVELOPE_M[name]:g} m (the "
                        f"profile's: {profile.procedure.max_depth_excursion_m:g} m)"
                        if check == "float" else "")
            print(f"  through the {CHECK_NAMES[check]}{envelope}: "
                  f"{sum(r.outcome == 'done' for r in loops)}/{seeds} loops done")
            for line in report(loops, profile.level_tol_deg, CHECK_NAMES[check]):
                print(f"    {line}")
