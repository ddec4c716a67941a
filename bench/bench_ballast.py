"""Ballast milp: solve time on both shipped vehicles beside linprog on its relaxation,
and on the degenerate Sabertooth cases (no or little static stability)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from bench.size import size
from bench.timing import best_time
from trimd.ballast.lp import build_programme, piece_items
from trimd.ballast.propose import propose_ballast
from trimd.ballast.stages import STAGE_NODES, solve_programme
from trimd.core.estimate import HoldSamples, StaticEstimate, estimate_static
from trimd.core.model import restoring_forces
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile

#: A payload per vehicle: mass [kg] at a position [m] (the thesis case for the Sabertooth),
#: and the largest mass [kg] of the random payloads (inside the weight slots' footprint).
CASES = {"sabertooth-dh2": (10.0, (-1.031, 0.6, 0.0), 6.0),
         "bluerov2-heavy": (0.3, (0.10, 0.08, 0.05), 0.4)}
#: Degenerate Sabertooth cases: 40 N heavy, net moment [N·m], estimate 1σ of q [N, N·m].
DEGENERATE = {"zero moment": (0.0, 0.0, 0.0), "m_z < 0": (1.0, 2.0, -5.0),
              "small m_z": (-20.0, 10.0, 5.0)}
DEGENERATE_Q_STD = (0.04, 0.097, 0.095, 0.306)


def _estimate(profile: Profile, mass_kg: float, r_m: tuple[float, float, float]
              ) -> StaticEstimate:
    """trimd's estimate from noise-free level and 20° holds with the payload aboard."""
    total = profile.mass_kg + mass_kg
    W, r_g = total * profile.gravity_m_s2, mass_kg * np.array(r_m) / total
    holds = []
    for k, deg in enumerate((0.0, 20.0)):
        a = np.radians(deg)
        tau = restoring_forces(a, a, W, profile.buoyancy_N, r_g, profile.r_b_m)
        holds.append(HoldSamples(np.arange(3.0) + 10 * k, np.full(3, a), np.full(3, a),
                                 np.tile(tau, (3, 1)), f"hold {k}"))
    return estimate_static(holds, profile)


def _spread(profile: Profile, max_kg: float, n: int = size(20, 2)
            ) -> tuple[list[float], list[float]]:
    """milp and relaxation solve times [s] over ``n`` seeded random payloads."""
    rng = np.random.default_rng(1)
    pos = np.array([s.position_m for s in profile.slots if s.max_weight_kg > 0])
    t_milp, t_lp = [], []
    for _ in range(n):
        r = rng.uniform(pos.min(axis=0), pos.max(axis=0))
        est = _estimate(profile, float(rng.uniform(0, max_kg)), (r[0], r[1], r[2] * 0.5))
        prog = build_programme(est, profile, piece_items(profile), level_tol_deg=0.25,
                               window_pct=profile.net_buoyancy_pct)
        t_milp.append(best_time(lambda prog=prog: solve_programme(prog), repeat=1))
        t_lp.append(best_time(lambda prog=prog: solve_programme(prog, relax=True), repeat=1))
    return t_milp, t_lp


def _degenerate(profile: Profile) -> None:
    """milp wall time [s] (one run each) on the degenerate cases, with the default limit."""
    for label, moment in size(DEGENERATE, dict(list(DEGENERATE.items())[:1])).items():
        est = _estimate(profile, 0.0, (0.0, 0.0, 0.0))
        q = np.r_[40.0, moment]
        est = dataclasses.replace(est, q=q, weight_N=est.buoyancy_N + 40.0,
                                  q_cov=np.diag(np.square(DEGENERATE_Q_STD)))
        t0 = time.perf_counter()
        p = propose_ballast(est, profile, "milp")
        print(f"{profile.name}, {label} {moment} N·m, 40 N heavy: milp "
              f"{time.perf_counter() - t0:.2f} s (budget {STAGE_NODES} nodes a stage); {p.message}")


def main() -> None:
    for name, (mass, r, max_kg) in CASES.items():
        profile = load_profile(name)
        est = _estimate(profile, mass, r)
        prog = build_programme(est, profile, piece_items(profile), level_tol_deg=0.25,
                               window_pct=profile.net_buoyancy_pct)
        t_milp = best_time(lambda prog=prog: solve_programme(prog))
        t_lp = best_time(lambda prog=prog: solve_programme(prog, relax=True))
        pieces = solve_programme(prog).amounts.sum()
        relaxed = solve_programme(prog, relax=True).amounts.sum()
        p = propose_ballast(est, profile, "milp")
        print(f"{name}, {mass:g} kg at {r}: milp {t_milp * 1e3:.1f} ms "
              f"({pieces:.0f} pieces, passive roll {p.trim.roll_deg:+.3f}°, pitch "
              f"{p.trim.pitch_deg:+.3f}°); linprog on the relaxation {t_lp * 1e3:.1f} ms "
              f"({relaxed:.2f} fractional pieces); ratio {t_milp / t_lp:.1f}×")
        t_m, t_r = _spread(profile, max_kg)
        print(f"{name}, {len(t_m)} random payloads ≤ {max_kg:g} kg: milp median "
              f"{np.median(t_m) * 1e3:.1f} ms, max {max(t_m) * 1e3:.1f} ms; linprog on the "
              f"relaxation median {np.median(t_r) * 1e3:.1f} ms, max {max(t_r) * 1e3:.1f} ms")
    _degenerate(load_profile("sabertooth-dh2"))


if __name__ == "__main__":
    main()
