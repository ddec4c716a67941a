"""Write a synthetic hold CSV from the restoring-force model, with sensor and thrust noise.

A worked example of the CSV format ``trimd solve`` reads (``trimd/app/holdfile.py``).
The payload of the example is the thesis case, 10 kg at AftSB:

    python examples/make_holds.py sabertooth-dh2 10@AftSB holds.csv
    trimd solve holds.csv --profile sabertooth-dh2
"""

from __future__ import annotations

import sys

import numpy as np

from trimd.core.model import restoring_forces
from trimd.core.profile_yaml import load_profile


def main(profile_path: str, payload: str, out: str, seed: int = 1) -> None:
    profile = load_profile(profile_path)
    mass, _, slot = payload.partition("@")
    m_ext = float(mass)
    r_slot = np.array(profile.slot(slot).position_m)
    W = (profile.mass_kg + m_ext) * profile.gravity_m_s2
    r_g = m_ext * r_slot / (profile.mass_kg + m_ext)
    rng = np.random.default_rng(seed)
    rate_hz, seconds = 10.0, 60.0
    n = int(rate_hz * seconds)
    rows = []
    for k, h in enumerate(profile.holds):
        phi, theta = np.radians(h.roll_deg), np.radians(h.pitch_deg)
        tau = restoring_forces(phi, theta, W, profile.buoyancy_N, r_g, profile.r_b_m)
        scale = np.r_[np.full(3, np.abs(tau[:3]).max()), np.full(3, np.abs(tau[3:]).max())]
        for i in range(n):
            t = k * (seconds + 30.0) + i / rate_hz
            noisy = tau + 0.02 * scale * rng.standard_normal(6)
            att = np.degrees([phi, theta]) + 0.1 * rng.standard_normal(2)
            rows.append([t, *att, *noisy])
    header = "time_s,roll_deg,pitch_deg,X_N,Y_N,Z_N,K_Nm,M_Nm,N_Nm"
    np.savetxt(out, np.array(rows), delimiter=",", header=header, comments="", fmt="%.6f")


if __name__ == "__main__":
    main(*sys.argv[1:4])
