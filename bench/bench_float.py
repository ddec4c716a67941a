"""The float check after a trim's ballast (docs/method.md §8), judged by the TRUE vehicle.

Per seed and case (the BlueROV2 Heavy with 0.4 kg at W-aft-stbd, the Sabertooth with 10 kg
at AftSB; ``disturb=real,truth=perturbed``): the full trim (:func:`tests.helpers.sim_trim`),
its ``milp`` proposal fitted on the simulated vehicle, then a float check
(:class:`trimd.core.float_check.FloatCheck`) in the profile's depth envelope and in a wider
one (the Heavy 2 m, the Sabertooth 10 m: the simulator has no bottom). Printed per case and
envelope: how many floats gave a result; how often the truth
(:func:`trimd.drivers.sim.truth.passive_trim_deg` of the ballasted true vehicle) lay within
each angle's 95 % interval; the largest and mean |float − truth|; the 95 % half-widths;
the floating time (from letting go to the release, simulated seconds) and the depth change;
and the verdicts against the truth (right, wrong, undecided). The loop closed through the
float (float, correction, a second float) is :mod:`bench.bench_closed_loop`'s
(``TRIMD_LOOP_CHECK=float``), in the wider envelopes of :data:`WIDE_ENVELOPE_M`.
``TRIMD_FLOAT_SEEDS`` (default 10) seeds per case. One seed takes ≈ 5 s (Heavy) and ≈ 8 s
(Sabertooth) of one core.
"""

from __future__ import annotations

import os

import numpy as np

from bench.size import size
from tests.helpers import SimFloat, ballast_payload, sim_float, sim_trim
from trimd.ballast.proposal import Proposal
from trimd.core.floating import Z95, FloatResult, Verdict
from trimd.core.profile_yaml import load_profile

OPTIONS = "disturb=real,truth=perturbed"
#: The depth envelope [m] a float needs per profile, wider than the profile's own
#: (``max_depth_excursion_m``): the Heavy's proposals leave it rising 0.01–0.06 m/s, the
#: Sabertooth's pitch relaxes in ≈ 21 s while it rises ≈ 0.1 m/s (the simulator has no
#: bottom).
WIDE_ENVELOPE_M = {"bluerov2-heavy": 2.0, "sabertooth-dh2": 10.0}
#: (profile, payload) of each case
CASES = (("bluerov2-heavy", "0.4@W-aft-stbd"), ("sabertooth-dh2", "10@AftSB"))


def verdict_right(r: FloatResult, truth: tuple[float, float]) -> str:
    """``right``, ``wrong`` or ``undecided``: the float ``r``'s verdict about the vehicle
    whose TRUE passive roll and pitch are ``truth`` [deg]."""
    if r.verdict is Verdict.UNDECIDED:
        return "undecided"
    level = max(abs(truth[0]), abs(truth[1])) <= r.level_tol_deg
    return "right" if (r.verdict is Verdict.LEVEL) == level else "wrong"


def report(name: str, excursion: str, floats: list[SimFloat]) -> None:
    """The figures of ``floats`` in the depth envelope ``excursion`` (module docstring)."""
    done = [(f.floated, f.truth_deg) for f in floats if f.floated is not None]
    print(f"{name}, depth envelope {excursion}: {len(done)} of {len(floats)} gave a result")
    if not done:
        return
    err = np.array([[r.roll_deg - t[0], r.pitch_deg - t[1]] for r, t in done])
    half = np.array([[Z95 * r.roll_std_deg, Z95 * r.pitch_std_deg] for r, _ in done])
    time_s = [r.t_end_s - r.t_start_s + r.settle_s for r, _ in done]
    depth = [abs(r.depth_change_m) for r, _ in done]
    verdicts = [verdict_right(r, t) for r, t in done]
    print(f"  truth within the 95 % interval: {int((np.abs(err) <= half).sum())} of "
          f"{err.size} angles; |float − truth| max {np.abs(err).max():.3f}°, mean "
          f"{np.abs(err).mean():.3f}°, {int((np.abs(err).max(axis=1) <= 0.2).sum())} of "
          f"{len(done)} within 0.2°")
    print(f"  ± (95 %) {half.min():.2f}–{half.max():.2f}°; floating {min(time_s):.0f}–"
          f"{max(time_s):.0f} s; depth change {min(depth):.2f}–{max(depth):.2f} m")
    print(f"  verdicts: {verdicts.count('right')} right, {verdicts.count('wrong')} wrong, "
          f"{verdicts.count('undecided')} undecided")


def main() -> None:
    seeds = range(int(os.environ.get("TRIMD_FLOAT_SEEDS", size(10, 1))))
    for name, payload in CASES:
        profile = load_profile(name)
        wide = WIDE_ENVELOPE_M[name]
        by_envelope: dict[float | None, list[SimFloat]] = {None: [], wide: []}
        for seed in seeds:
            trim = sim_trim(profile, payload, seed, OPTIONS)
            if not isinstance(trim.result.proposal, Proposal):
                print(f"{name} seed {seed}: no proposal ({trim.result.reason})")
                continue
            ballasted = f"{payload}+{ballast_payload(trim.result.proposal, profile)}"
            for excursion, floats in by_envelope.items():
                floats.append(sim_float(profile, ballasted, seed, OPTIONS, excursion))
        report(name, f"{profile.procedure.max_depth_excursion_m:g} m (the profile's)",
               by_envelope[None])
        report(name, f"{wide:g} m", by_envelope[wide])


if __name__ == "__main__":
    main()
