"""The closed loop (issue 24): trim → apply → verify → at most one correction → apply →
verify, on simulated vehicles that their profiles do not describe exactly, judged by the
TRUE vehicle.

Per seed and case (:data:`bench.bench_sim_coverage.CASES`: the BlueROV2 Heavy with a payload
at a slot and with a small payload, the Sabertooth with 10 kg at AftSB): the full trim
(:func:`tests.helpers.sim_trim`); its ``milp`` proposal recorded as installed
(:func:`trimd.app.apply.apply_ballast`, in a history of the seed's own) and fitted on the
simulated vehicle (its pieces as payload items at their slots: the sim's ballast changes);
a verify hold (:func:`tests.helpers.sim_verify`, the same seed: the same true vehicle);
when that asks for one (:func:`trimd.ballast.correct.needs_correction`), the correction
from the verify hold (:func:`trimd.ballast.correct.propose_correction`) recorded and
fitted whether or not it is ``feasible`` (the best achievable, as a trim's proposal), and
a second verify hold of it. The loop stops there, whatever that hold says.

Judged by the simulator's truth (:func:`trimd.drivers.sim.truth.passive_trim_deg` of the
true vehicle with every piece fitted so far, thrusters off; roll and pitch [deg]): the
share of seeds within the profile's level tolerance on both axes after one trim and after
the loop, the worst |roll| and |pitch|, how many needed a correction (and why: NOT level,
NOT as predicted), how often each verify hold's verdict "level" / "NOT level" was right
about the true vehicle, and the loop's diving time (simulated: every session from its
start) beside a trim followed by a second full trim of the ballasted vehicle (its two
holds, one tilted: what the operator does without the loop), timed on the first
``TRIMD_LOOP_SECOND_TRIMS`` seeds. Seeds whose trim or a verify hold did not end DONE
count as outside the tolerance (the loop did not deliver) and are listed.

``TRIMD_LOOP_SEEDS`` (default 200) seeds per case; ``TRIMD_LOOP_OPTIONS`` the sim options
(default ``disturb=real,truth=perturbed,thrust_err_max=0.1``: realistic disturbances, thrust
curves 5–10 % off, ESC dead bands up to 4 µs off with outputs hunting at their edge);
``TRIMD_LOOP_SECOND_TRIMS`` (default 20); ``TRIMD_LOOP_CASES`` comma-separated words
picking cases; ``TRIMD_COVERAGE_PROCESSES`` (default 1) worker processes. One seed takes
≈ 5 s (Heavy) and ≈ 10 s (Sabertooth) of one core, plus a trim's for a second trim.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.bench_sim_coverage import CASES, picked, run_seeds
from bench.size import size
from tests.helpers import carried, sim_trim, sim_verify
from trimd.app.apply import apply_ballast
from trimd.ballast.check import SlotLoad
from trimd.ballast.correct import needs_correction, propose_correction
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import Verification
from trimd.core.errors import DataError, ProfileError
from trimd.core.events import Phase
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.truth import passive_trim_deg
from trimd.drivers.sim.vehicle import SimVehicle

OPTIONS = "disturb=real,truth=perturbed,thrust_err_max=0.1"


@dataclass(frozen=True)
class Hold:
    """One verify hold of the loop: its verdict, the TRUE vehicle's passive roll and pitch
    [deg] while it was held (the ballast fitted then), the simulated time it took [s]."""

    level: bool
    as_predicted: bool
    true_deg: tuple[float, float]
    sim_s: float


@dataclass(frozen=True)
class Loop:
    """One seed's loop: ``outcome`` "done" or where it stopped; the trim's simulated time
    [s]; the TRUE roll and pitch [deg] with the trim's proposal fitted (``after_trim``)
    and at the end of the loop (``after_loop``); the verify holds; the correction's
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


def _true_deg(vehicle: SimVehicle, loads: tuple[SlotLoad, ...]) -> tuple[float, float]:
    """Roll and pitch [deg] at which the TRUE ``vehicle`` floats, thrusters off, with
    ``loads`` fitted at their positions."""
    return passive_trim_deg(vehicle.ballasted(carried(loads, vehicle.profile.gravity_m_s2)).net)


def run(name: str, payload: str, seed: int, options: str, second_trim: bool) -> Loop:
    """The loop of ``seed`` (module docstring)."""
    profile = load_profile(name)
    trial = sim_trim(profile, payload, seed, options)
    estimate, proposal = trial.result.estimate, trial.result.proposal
    if trial.result.phase is not Phase.DONE or estimate is None or not isinstance(
            proposal, Proposal):
        return Loop(seed, f"trim: {trial.result.reason}", trial.vehicle.t_s)
    holds: list[Hold] = []
    fitted: tuple[SlotLoad, ...] = ()
    feasible, message, second_s = None, "", None
    with tempfile.TemporaryDirectory() as tmp:
        db = Path(tmp) / "trimd.db"
        try:
            applied = apply_ballast(db, "bench", profile, estimate=estimate, proposal=proposal)
            fitted = applied.loads
            after_trim = _true_deg(trial.vehicle, fitted)
            if second_trim:
                again = sim_trim(profile, f"{payload}+{carried(fitted, profile.gravity_m_s2)}",
                                 seed, options)
                second_s = again.vehicle.t_s if again.result.phase is Phase.DONE else None
            target, installed = estimate, applied.loads
            while True:
                hold = sim_verify(profile, payload, seed, options, target, installed, fitted)
                v = hold.result.verification
                if hold.result.phase is not Phase.DONE or not isinstance(v, Verification):
                    return Loop(seed, f"verify {len(holds) + 1}: {hold.result.reason}",
                                trial.vehicle.t_s, after_trim, _true_deg(trial.vehicle, fitted),
                                tuple(holds), feasible, message, second_s)
                holds.append(Hold(v.level, v.as_predicted, _true_deg(trial.vehicle, fitted),
                                  hold.t_s))
                if len(holds) > 1 or not needs_correction(v):
                    break
                c = propose_correction(v, target, profile, applied.installed)
                feasible, message = c.proposal.feasible, c.proposal.message
                applied = apply_ballast(db, "bench", profile, estimate=c.vehicle,
                                        proposal=c.proposal)
                target, installed = c.vehicle, applied.loads
                fitted = fitted + applied.loads
        except (DataError, ProfileError) as exc:
            return Loop(seed, f"apply or correction: {exc}", trial.vehicle.t_s)
    return Loop(seed, "done", trial.vehicle.t_s, after_trim, _true_deg(trial.vehicle, fitted),
                tuple(holds), feasible, message, second_s)


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


def report(runs: list[Loop], tol_deg: float) -> list[str]:
    """The figures of ``runs`` for people (module docstring), one string per line."""
    done = [r for r in runs if r.outcome == "done"]
    first = [r.holds[0] for r in runs if r.holds]
    second = [r.holds[1] for r in runs if len(r.holds) > 1]
    needed = [r for r in runs if r.corrected]
    lines = [
        f"true vehicle within the level tolerance ({tol_deg:g}°): after one trim "
        f"{_share([_within(r.after_trim, tol_deg) for r in runs])}, after the loop "
        f"{_share([_within(r.after_loop, tol_deg) and r.outcome == 'done' for r in runs])}",
        f"worst after one trim {_worst([r.after_trim for r in runs])}; after the loop "
        f"{_worst([r.after_loop for r in runs])}",
        f"correction needed {_share([r.corrected for r in runs])}: the first verify hold said "
        f"NOT level {sum(not h.level for h in first)}, NOT as predicted "
        f"{sum(not h.as_predicted for h in first)}; correction not feasible "
        f"{sum(r.correction_feasible is False for r in needed)}",
        f"verdict right about the true vehicle: first verify hold "
        f"{_share([h.level == _within(h.true_deg, tol_deg) for h in first])}, after the "
        f"correction {_share([h.level == _within(h.true_deg, tol_deg) for h in second])}; "
        f"said level while the true vehicle was not: "
        f"{sum(h.level and not _within(h.true_deg, tol_deg) for h in first + second)}"]
    loop_s = [r.trim_s + sum(h.sim_s for h in r.holds) for r in done]
    timed = [r for r in done if r.second_trim_s is not None]
    if loop_s:
        verify_s = [h.sim_s for h in first + second]
        line = (f"diving time (simulated): loop {np.mean(loop_s):.0f} s mean, "
                f"{np.max(loop_s):.0f} s max (trim {np.mean([r.trim_s for r in done]):.0f} s, "
                f"verify hold {np.mean(verify_s):.0f} s)")
        if timed:
            both = np.mean([r.trim_s + (r.second_trim_s or 0.0) for r in timed])
            loops = np.mean([r.trim_s + sum(h.sim_s for h in r.holds) for r in timed])
            line += (f"; on {len(timed)} seeds trim + a second full trim {both:.0f} s, "
                     f"their loop {loops:.0f} s ({loops / both:.0%} of it)")
        lines.append(line)
    for r in [r for r in runs if not (_within(r.after_loop, tol_deg) and r.outcome == "done")
              ][:size(12, 2)]:
        angles = " → ".join(f"({a[0]:+.2f}°, {a[1]:+.2f}°)" for a in (r.after_trim,
                                                                     r.after_loop) if a)
        verdicts = ", ".join(f"{'level' if h.level else 'NOT level'}"
                             f"{'' if h.as_predicted else ' NOT as predicted'}" for h in r.holds)
        lines.append(f"  outside: seed {r.seed} {r.outcome[:60]}: true {angles}; verify "
                     f"{verdicts or '—'}; {r.correction[:90] or 'no correction'}")
    return lines


def main() -> None:
    seeds = int(os.environ.get("TRIMD_LOOP_SEEDS", size(200, 1)))
    options = os.environ.get("TRIMD_LOOP_OPTIONS", OPTIONS)
    second = int(os.environ.get("TRIMD_LOOP_SECOND_TRIMS", size(20, 1)))
    processes = int(os.environ.get("TRIMD_COVERAGE_PROCESSES", "1"))
    wanted = os.environ.get("TRIMD_LOOP_CASES", "")
    for name, payload in picked(size(CASES, CASES[:1]), wanted):
        runs, wall = run_seeds(run, name, payload, seeds, options, processes,
                               [s < second for s in range(seeds)])
        print(f"{name}, {payload}, sim:{options}: "
              f"{sum(r.outcome == 'done' for r in runs)}/{seeds} loops done, "
              f"{wall:.1f} s wall per seed")
        for line in report(runs, load_profile(name).level_tol_deg):
            print(f"  {line}")
