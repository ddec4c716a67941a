"""Ballast milp from the installed ballast against adding only, on the BlueROV2 Heavy:
50 seeded random cases of installed lead and foam plus a random payload (the cases of
tests/ballast/test_installed.py). Prints how often each is feasible, the pieces handled
where both are, how many proposals move or remove pieces, and the solve times."""

from __future__ import annotations

import time

import numpy as np

from bench.size import size
from tests.ballast.test_installed import _random_case, final_attitude, scenario
from trimd.core.profile_yaml import load_profile


def main(n: int = size(50, 2)) -> None:
    profile = load_profile("bluerov2-heavy")
    rng = np.random.default_rng(2026)
    rows, seconds = [], []
    for _ in range(n):
        installed, payload = _random_case(profile, rng)
        t0 = time.perf_counter()
        p, add_only = scenario(profile, installed, payload)
        seconds.append(time.perf_counter() - t0)
        if p.feasible:  # independent physics of the final configuration
            roll, pitch, _ = final_attitude(profile, payload, p)
            assert max(abs(roll), abs(pitch)) <= profile.level_tol_deg + 1e-9
        rows.append((p.feasible, add_only.feasible, p.pieces_handled,
                     add_only.pieces_handled, any(c.action == "move" for c in p.changes),
                     any(c.action == "remove" for c in p.changes)))
    ok = np.array([r[0] for r in rows])
    ok_add = np.array([r[1] for r in rows])
    handled = np.array([r[2] for r in rows])
    handled_add = np.array([r[3] for r in rows])
    both = ok & ok_add
    print(f"{n} cases: feasible from the installed ballast {ok.sum()}, adding only "
          f"{ok_add.sum()}")
    print(f"both feasible ({both.sum()}): pieces handled {handled[both].mean():.2f} against "
          f"{handled_add[both].mean():.2f} (fewer in {(handled[both] < handled_add[both]).sum()},"
          f" more in {(handled[both] > handled_add[both]).sum()})")
    print(f"proposals that move pieces {sum(r[4] for r in rows)}, that remove pieces "
          f"{sum(r[5] for r in rows)}")
    print(f"both proposals per case: median {np.median(seconds) * 1e3:.0f} ms, max "
          f"{max(seconds) * 1e3:.0f} ms")
