"""Calibration of the estimate's ± on the simulated vehicle (issue 12): over seeded full
trims with realistic disturbances, how often the 95 % interval of each quantity covers the
truth, and the RMS of error/σ (1 when the σ is right).

Quantities: W − B and the three components of W·r_g − B·r_b ("x net" …) against the TRUE
q; m_ext and r_g against what an exact estimate of the true q reads through the nominal
profile (``trimd.drivers.sim.truth.implied_mass``). A run that does not end DONE counts as a
failure, not in the coverage. ``TRIMD_COVERAGE_SEEDS`` (default 200) seeds per profile;
``TRIMD_COVERAGE_OPTIONS`` the sim options (default ``disturb=real,truth=perturbed``:
realistic disturbances on a vehicle whose buoyancy, centre of buoyancy and thrust curves
differ from its profile); ``TRIMD_COVERAGE_PROCESSES`` (default 1) worker processes;
``TRIMD_COVERAGE_CASES`` a comma-separated list of words picking cases (default all). One
run takes ≈ 2 s (BlueROV2 Heavy) and ≈ 3 s (Sabertooth) of one core.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from bench.size import size
from tests.helpers import SimTrim, sim_trim
from trimd.ballast.propose import Proposal
from trimd.core.events import Phase
from trimd.core.profile_yaml import load_profile

#: (profile, hidden payload) of each coverage set: the BlueROV2 Heavy with a payload at a
#: ballast slot, a small-payload Heavy (W − B ≈ 2.4 N, the payload 0.14 m from the
#: centre: its thrusters work at their dead band), the thesis's Sabertooth
CASES = (("bluerov2-heavy", "0.4@W-aft-stbd"), ("bluerov2-heavy", "0.48@0.08,-0.1,0.06"),
         ("sabertooth-dh2", "10@AftSB"))
FloatArray = NDArray[np.float64]
T = TypeVar("T")
NAMES = ("W − B", "x net", "y net", "z net", "m_ext", "x_g", "y_g", "z_g")
Z95 = 1.959964


@dataclass(frozen=True)
class Run:
    """One seeded trim: errors and σ of :data:`NAMES` (None when it did not end DONE),
    its outcome and the simulated time it took [s]; ``trim``: the TRUE vehicle's roll and
    pitch with the milp proposal on it, the proposal's predicted roll and pitch and their
    1σ [deg]."""

    seed: int
    outcome: str
    sim_s: float
    error: tuple[float, ...] | None
    sigma: tuple[float, ...] | None
    trim: tuple[float, ...] | None = None


def run(profile_name: str, payload: str, seed: int, options: str) -> Run:
    """One full trim of ``seed``; errors against the truth (module docstring)."""
    return judge(seed, sim_trim(load_profile(profile_name), payload, seed, options))


def judge(seed: int, trial: SimTrim) -> Run:
    """The trim ``trial`` of ``seed`` judged against its simulator's truth."""
    est = trial.result.estimate
    if trial.result.phase is not Phase.DONE or est is None:
        return Run(seed, trial.result.reason, trial.vehicle.t_s, None, None)
    m_ext, r_g = trial.implied_truth
    error = np.r_[est.q - trial.q_true, est.m_ext_kg - m_ext, est.r_g_m - r_g]
    sigma = np.r_[np.sqrt(np.diag(est.q_cov)), est.m_ext_std_kg, est.r_g_std_m]
    proposal = trial.result.proposal
    assert isinstance(proposal, Proposal)
    trim = (*trial.trim_after_proposal_deg(), proposal.trim.roll_deg, proposal.trim.pitch_deg,
            *proposal.trim_std_deg)
    return Run(seed, "done", trial.vehicle.t_s, tuple(map(float, error)),
               tuple(map(float, sigma)), tuple(map(float, trim)))


@dataclass(frozen=True)
class TrimOutcome:
    """The milp proposal on the true vehicle over the DONE runs: the share whose true trim
    is within the level tolerance or within the predicted trim ± its 95 % interval on
    both axes (``as_said``), the RMS of (true − predicted)/σ of roll and pitch, the
    largest true |roll| or |pitch| [deg], the share left beyond twice the tolerance, and
    the share of those that the proposal called undecided (its 95 % interval of the trim
    wider than the tolerance)."""

    as_said: float
    rms_z: FloatArray
    worst_deg: float
    beyond_twice: float
    beyond_said_undecided: float


def trim_as_said(runs: list[Run], level_tol_deg: float) -> TrimOutcome:
    """:class:`TrimOutcome` of the DONE runs."""
    t = np.array([r.trim for r in runs if r.trim is not None]).reshape(-1, 6)
    after, predicted, sigma = t[:, :2], t[:, 2:4], t[:, 4:]
    z = (after - predicted) / sigma
    said = np.all((np.abs(after) <= level_tol_deg) | (np.abs(z) <= Z95), axis=1)
    beyond = np.any(np.abs(after) > 2 * level_tol_deg, axis=1)
    undecided = Z95 * sigma.max(axis=1) > level_tol_deg
    return TrimOutcome(float(said.mean()), np.sqrt(np.mean(z**2, axis=0)),
                       float(np.abs(after).max()), float(beyond.mean()),
                       float(undecided[beyond].mean()) if beyond.any() else 1.0)


def coverage(runs: list[Run]) -> tuple[np.ndarray, np.ndarray, int]:
    """Per quantity: fraction of DONE runs whose 95 % interval covers the truth, RMS of
    error/σ; and the number of DONE runs."""
    done = [r for r in runs if r.error is not None and r.sigma is not None]
    if not done:
        return np.full(len(NAMES), np.nan), np.full(len(NAMES), np.nan), 0
    z = np.array([np.divide(r.error, r.sigma) for r in done])
    return np.mean(np.abs(z) <= Z95, axis=0), np.sqrt(np.mean(z ** 2, axis=0)), len(done)


def rms_errors(runs: list[Run], weight_N: float) -> FloatArray:
    """RMS error over the DONE runs of W − B [N] and of the three net moments in
    mm-equivalent (error [N·m] / ``weight_N``, the nominal weight [N], × 1000); NaN without
    a DONE run."""
    errors = np.array([r.error[:4] for r in runs if r.error is not None]).reshape(-1, 4)
    if not len(errors):
        return np.full(4, np.nan)
    rms = np.sqrt(np.mean(errors**2, axis=0))
    return np.r_[rms[0], 1e3 * rms[1:] / weight_N]


@dataclass(frozen=True)
class Seeding:
    """How a seeded bench runs: seeds 0 … ``seeds`` − 1 per case, the sim ``options``, the
    worker ``processes``, the words that pick cases (``wanted``, :func:`picked`)."""

    seeds: int
    options: str
    processes: int
    wanted: str


def seeding(prefix: str, seeds: int, options: str) -> Seeding:
    """The :class:`Seeding` of ``TRIMD_<prefix>_SEEDS`` (default ``seeds``),
    ``TRIMD_<prefix>_OPTIONS`` (default ``options``), ``TRIMD_<prefix>_CASES`` (default:
    every case) and ``TRIMD_COVERAGE_PROCESSES`` (default 1)."""
    env = os.environ.get
    return Seeding(int(env(f"TRIMD_{prefix}_SEEDS", seeds)),
                   env(f"TRIMD_{prefix}_OPTIONS", options),
                   int(env("TRIMD_COVERAGE_PROCESSES", "1")), env(f"TRIMD_{prefix}_CASES", ""))


def picked(cases: Sequence[tuple[str, str]], wanted: str) -> list[tuple[str, str]]:
    """The (profile, payload) ``cases`` whose "profile payload" holds one of the
    comma-separated words of ``wanted`` (every case when it is empty)."""
    return [(name, payload) for name, payload in cases
            if not wanted or any(w in f"{name} {payload}" for w in wanted.split(","))]


def run_seeds(fn: Callable[..., T], name: str, payload: str, seeds: int, options: str,
              processes: int, *extra: Iterable[object]) -> tuple[list[T], float]:
    """``fn(name, payload, seed, options, *extra)`` for seeds 0 … ``seeds`` − 1 in
    ``processes`` worker processes (``extra``: one more argument per seed each); the
    results and the wall time per seed [s]."""
    t0 = time.perf_counter()
    with ProcessPoolExecutor(processes) as pool:
        runs = list(pool.map(fn, [name] * seeds, [payload] * seeds, range(seeds),
                             [options] * seeds, *extra))
    return runs, (time.perf_counter() - t0) / seeds


def main() -> None:
    cfg = seeding("COVERAGE", size(200, 1), "disturb=real,truth=perturbed")
    seeds, options = cfg.seeds, cfg.options
    # at the tiny size one case per profile: the Heavy's small payload runs the first
    # case's code with other numbers
    for name, payload in picked(size(CASES, (CASES[0], CASES[-1])), cfg.wanted):
        runs, wall = run_seeds(run, name, payload, seeds, options, cfg.processes)
        covered, rms, n_done = coverage(runs)
        print(f"{name}, {payload}, sim:{options}: {n_done}/{seeds} runs done, "
              f"{wall:.1f} s wall and {np.mean([r.sim_s for r in runs]):.0f} s "
              f"simulated per run")
        print("  " + " ".join(f"{n:>7s}" for n in ("", *NAMES)))
        print("  " + f"{'cover':>7s} " + " ".join(f"{c:7.0%}" for c in covered))
        print("  " + f"{'rms z':>7s} " + " ".join(f"{v:7.2f}" for v in rms))
        rms_err = rms_errors(runs, load_profile(name).weight_N)
        print(f"  rms error: W − B {rms_err[0]:.3f} N, net moments "
              + ", ".join(f"{v:.2f}" for v in rms_err[1:])
              + " mm-equivalent (error / nominal weight)")
        o = trim_as_said(runs, load_profile(name).level_tol_deg)
        print(f"  proposal on the true vehicle: within the level tolerance or the predicted "
              f"trim ±95 % in {o.as_said:.0%}; rms z roll {o.rms_z[0]:.2f}, pitch "
              f"{o.rms_z[1]:.2f}; worst |angle| {o.worst_deg:.2f}°; beyond twice the "
              f"tolerance {o.beyond_twice:.0%}, of those said undecided "
              f"{o.beyond_said_undecided:.0%}")
        failed = [f"seed {r.seed}: {r.outcome}" for r in runs if r.error is None]
        for line in failed[:3]:
            print(f"  failed {line[:110]}")
