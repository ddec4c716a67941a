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
and the verdicts against the truth (right, wrong, undecided). Then the loop closed through
the wider envelope's float: where it did not float level, the correction from the attitude
it floated at (:func:`trimd.ballast.correct.propose_float_correction`) fitted too, and
how many TRUE vehicles end within the level tolerance, against the trim's ballast alone.
``TRIMD_FLOAT_SEEDS``
(default 10) seeds per case. One seed takes ≈ 5 s (Heavy) and ≈ 8 s (Sabertooth) of one
core.
"""

from __future__ import annotations

import asyncio
import os
from dataclasses import dataclass

import numpy as np

from bench.size import size
from tests.helpers import SimTrim, ballast_payload, carried, sim_trim
from trimd.app.connect import open_link
from trimd.app.float_check import FloatRequest, float_session
from trimd.ballast.changes import change_loads
from trimd.ballast.correct import propose_float_correction
from trimd.ballast.proposal import Proposal
from trimd.core.floating import Z95, FloatResult, Verdict
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.truth import passive_trim_deg

OPTIONS = "disturb=real,truth=perturbed"
#: (profile, payload, the wider depth envelope [m])
CASES = (("bluerov2-heavy", "0.4@W-aft-stbd", 2.0), ("sabertooth-dh2", "10@AftSB", 10.0))


@dataclass(frozen=True)
class Floated:
    """One float: its result (None: it failed, ``reason``) and the true trim [deg]."""

    result: FloatResult | None
    truth_deg: tuple[float, float]
    reason: str


def float_once(profile: Profile, payload: str, seed: int, excursion_m: float | None
               ) -> Floated:
    async def go() -> Floated:
        link = await open_link(f"sim:payload={payload},seed={seed},{OPTIONS}", profile)
        session = float_session(link, profile, [], FloatRequest(
            profile.name, confirmed=True, depth_excursion_m=excursion_m), wall_clock=False)
        result = await session.run()
        truth = passive_trim_deg(link.vehicle.truth.mass.net)  # type: ignore[attr-defined]
        r = result.verification
        return Floated(r if isinstance(r, FloatResult) else None, truth, result.reason)
    return asyncio.run(go())


def _verdict_right(r: FloatResult, truth: tuple[float, float]) -> str:
    if r.verdict is Verdict.UNDECIDED:
        return "undecided"
    level = max(abs(truth[0]), abs(truth[1])) <= r.level_tol_deg
    return "right" if (r.verdict is Verdict.LEVEL) == level else "wrong"


def report(name: str, excursion: str, floats: list[Floated]) -> None:
    done = [f for f in floats if f.result is not None]
    print(f"{name}, depth envelope {excursion}: {len(done)} of {len(floats)} gave a result")
    if not done:
        return
    err = np.array([[f.result.roll_deg - f.truth_deg[0], f.result.pitch_deg - f.truth_deg[1]]
                    for f in done if f.result])
    half = np.array([[Z95 * f.result.roll_std_deg, Z95 * f.result.pitch_std_deg]
                     for f in done if f.result])
    time_s = [f.result.t_end_s - f.result.t_start_s + f.result.settle_s for f in done
              if f.result]
    depth = [abs(f.result.depth_change_m) for f in done if f.result]
    verdicts = [_verdict_right(f.result, f.truth_deg) for f in done if f.result]
    print(f"  truth within the 95 % interval: {int((np.abs(err) <= half).sum())} of "
          f"{err.size} angles; |float − truth| max {np.abs(err).max():.3f}°, mean "
          f"{np.abs(err).mean():.3f}°, {int((np.abs(err).max(axis=1) <= 0.2).sum())} of "
          f"{len(done)} within 0.2°")
    print(f"  ± (95 %) {half.min():.2f}–{half.max():.2f}°; floating {min(time_s):.0f}–"
          f"{max(time_s):.0f} s; depth change {min(depth):.2f}–{max(depth):.2f} m")
    print(f"  verdicts: {verdicts.count('right')} right, {verdicts.count('wrong')} wrong, "
          f"{verdicts.count('undecided')} undecided")


def corrected_trim_deg(trim: SimTrim, profile: Profile, proposal: Proposal, f: Floated
                       ) -> tuple[float, float]:
    """The TRUE vehicle's passive roll and pitch [deg] with the trim's ``proposal`` fitted
    and, unless the float ``f`` found it level, the correction from the float too."""
    r, estimate = f.result, trim.result.estimate
    if r is None or estimate is None or r.verdict is Verdict.LEVEL:
        return f.truth_deg
    loads = change_loads(profile, proposal.installed, proposal.installed_after)
    c = propose_float_correction(r, estimate, loads, profile, proposal.installed_after)
    g = profile.gravity_m_s2
    extra = "+".join(filter(None, (carried(ld, g) for ld in (loads, c.proposal.slots))))
    return passive_trim_deg(trim.vehicle.ballasted(extra).net)


def report_loop(name: str, tol_deg: float, pairs: list[tuple[tuple[float, float],
                                                            tuple[float, float]]]) -> None:
    """Before (the trim's ballast) and after (the float's correction too), the TRUE trim."""
    before = np.array([max(map(abs, b)) for b, _ in pairs])
    after = np.array([max(map(abs, a)) for _, a in pairs])
    print(f"{name}, trim → ballast → float → correction: within the level tolerance "
          f"({tol_deg:g}°) {int((after <= tol_deg).sum())} of {len(pairs)} (the trim's "
          f"ballast alone: {int((before <= tol_deg).sum())}); largest |roll|, |pitch| "
          f"{before.max():.2f}° → {after.max():.2f}°, RMS {np.sqrt(np.mean(before**2)):.2f}° "
          f"→ {np.sqrt(np.mean(after**2)):.2f}°")


def main() -> None:
    seeds = range(int(os.environ.get("TRIMD_FLOAT_SEEDS", size(10, 1))))
    for name, payload, wide in CASES:
        profile = load_profile(name)
        by_envelope: dict[float | None, list[Floated]] = {None: [], wide: []}
        loop = []
        for seed in seeds:
            trim = sim_trim(profile, payload, seed, OPTIONS)
            if not isinstance(trim.result.proposal, Proposal):
                print(f"{name} seed {seed}: no proposal ({trim.result.reason})")
                continue
            ballasted = f"{payload}+{ballast_payload(trim.result.proposal, profile)}"
            for excursion in by_envelope:
                by_envelope[excursion].append(float_once(profile, ballasted, seed, excursion))
            f = by_envelope[wide][-1]
            if f.result is not None:
                loop.append((f.truth_deg, corrected_trim_deg(trim, profile,
                                                             trim.result.proposal, f)))
        report(name, f"{profile.procedure.max_depth_excursion_m:g} m (the profile's)",
               by_envelope[None])
        report(name, f"{wide:g} m", by_envelope[wide])
        if loop:
            report_loop(name, profile.level_tol_deg, loop)


if __name__ == "__main__":
    main()
