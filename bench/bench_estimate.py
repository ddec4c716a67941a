"""Static estimator: a 2-hold, 20 000-sample solve beside plain numpy.linalg.lstsq."""

from __future__ import annotations

import numpy as np

from bench.size import size
from bench.timing import best_time
from trimd.core.estimate import HoldSamples, estimate_static
from trimd.core.model import restoring_forces, restoring_matrix
from trimd.core.profile_yaml import load_profile


def main() -> None:
    profile = load_profile("sabertooth-dh2")
    rng = np.random.default_rng(0)
    W, r_g = (profile.mass_kg + 10) * profile.gravity_m_s2, np.array([-0.0086, 0.005, 0.0])
    holds = []
    for k, deg in enumerate((0.0, 20.0)):
        a = np.radians(deg)
        tau = restoring_forces(a, a, W, profile.buoyancy_N, r_g, profile.r_b_m)
        n = size(10_000, 200)
        holds.append(HoldSamples(np.arange(n) * 0.02 + 300 * k,
                                 a + 1e-3 * rng.standard_normal(n),
                                 a + 1e-3 * rng.standard_normal(n),
                                 tau + rng.standard_normal((n, 6)), f"hold {k}"))
    A = np.concatenate([restoring_matrix(h.phi, h.theta).reshape(-1, 4) for h in holds])
    y = np.concatenate([h.tau.reshape(-1) for h in holds])
    t_est = best_time(lambda: estimate_static(holds, profile))
    t_ref = best_time(lambda: np.linalg.lstsq(A, y, rcond=None))
    # the reference is one unweighted solve over every row of every sample; the estimator
    # also weights the rows, drops the tilted hold's force rows and propagates covariances
    print(f"estimate_static 2 holds × {len(holds[0].t_s):,} samples: {t_est * 1e3:.1f} ms; "
          f"one numpy.linalg.lstsq over all {len(y):,} × 4 rows of the same holds: "
          f"{t_ref * 1e3:.1f} ms; ratio {t_est / t_ref:.1f}×")


if __name__ == "__main__":
    main()
