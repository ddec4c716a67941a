"""The band calibration's series (``trimd calibrate --band``, docs/method.md §7): after the
first level hold of a trimmed vehicle, the load that makes it just heavy enough for each
of its vertical thrusters to hunt at the upper edge of its dead band
(:func:`~trimd.ballast.band.band_load`), a level hold with it, and when that hold does not
show every lifting thruster's upper edge (:func:`~trimd.ballast.band.unhunted`) the load
aimed again from it, up to :data:`BAND_TRIES` holds in all; then the same for the lower
edges, the vehicle just buoyant enough.

Each load is designed from the latest hold, its W − B and x, y net moments read with the
calibration so far (which the holds before taught, the edges they showed among it), less
what the load then hung adds: the vehicle without a load, as that hold reads it. A load
that misses a thruster's window (on the Sabertooth 1.2 N wide, 0.9 m from its centre)
leaves that edge unread, and the gain of the thruster's first µs with it (docs/method.md
§7).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import replace

import numpy as np

from trimd.app.calibration_loads import (
    CalibrationRun,
    KnownWeight,
    Load,
    calibration_experiment,
    load_change,
    swap_text,
)
from trimd.ballast.band import band_load, unhunted
from trimd.core.calibration import Experiment, Outcome, ThrustMapPosterior, ballast_change
from trimd.core.errors import UsageError
from trimd.core.estimate import HoldSamples
from trimd.core.output_hist import spikes_seen
from trimd.core.profile import Profile
from trimd.core.segment import estimate_segment
from trimd.core.types import FloatArray

__all__ = ["BAND_TRIES", "band_series"]

#: The most level holds per band side: the first load's, and a load aimed again from each
#: hold that did not show every lifting thruster's edge.
BAND_TRIES = 3

#: One hold of the series: its index (0: the first, before any load), the loads so far and
#: their sides (True: the upper edges').
Hold = Callable[[int, tuple[Load, ...], tuple[bool, ...]], Awaitable[HoldSamples]]
#: An experiment checked against, and added to, the calibration so far.
Learn = Callable[[Experiment, ThrustMapPosterior], tuple[ThrustMapPosterior, Outcome]]


async def band_series(hold: Hold, learn: Learn, hung: Callable[[str, Load], bool],
                      profile: Profile, post: ThrustMapPosterior, uncertainty_pct: float,
                      tries: int = BAND_TRIES) -> CalibrationRun:
    """The band calibration (module docstring): ``hold`` makes each level hold, ``learn``
    checks and adds each experiment of two consecutive holds to the calibration ``post``
    (``profile``'s when it starts), ``hung(text, load)`` has the operator swap the load on
    for ``load`` (False: the series stops there; before the first load: UsageError), each
    load's weights known to ``uncertainty_pct`` [%, 1σ]; at most ``tries`` holds per
    side. An experiment that disagrees with the calibration stops the series: the loads
    after it would be aimed from a vehicle that is not what the hold read."""
    holds = [await hold(0, (), ())]
    series: list[Load] = []
    experiments: list[Experiment] = []
    outcomes: list[Outcome] = []
    sides: list[bool] = []
    on: Load = ()

    def run(stopped: str = "") -> CalibrationRun:
        return CalibrationRun(tuple(experiments), tuple(outcomes), post, profile, stopped,
                              tuple(sides))

    for upward in (True, False):
        missed: tuple[int, ...] = ()
        for _ in range(tries):
            load, text = _aimed(holds[-1], on, missed, replace(profile, thrust_map=post),
                                upward, uncertainty_pct)
            if not load or load == on:
                break
            if not hung(text + swap_text(load, on or None, profile), load):
                if not series:
                    raise UsageError("calibration aborted: the weight was not hung",
                                     "trimd calibrate")
                return run(f"stopped by the operator after {len(series)} band loads")
            series.append(load)
            holds.append(await hold(len(series), tuple(series), (*sides, upward)))
            exp = calibration_experiment(holds[-2], holds[-1], profile, load, on or None)
            post, outcome = learn(exp, post)
            experiments.append(exp)
            outcomes.append(outcome)
            sides.append(upward)
            if not outcome.accepted:     # the next load would be aimed from a wrong one
                return run("the band series stopped at the experiment that disagreed: "
                           "check that what is hung is what trimd asked for, then "
                           "calibrate again")
            on = load
            after = exp.after.outputs      # the hold's outputs, as the calibration reads them
            missed = () if after is None else unhunted(profile, spikes_seen(after, profile),
                                                       upward)
            if not missed:
                break
    return run()


def _hunted_text(profile: Profile, missed: tuple[int, ...], upward: bool) -> str:
    """Which thrusters the last hold did not see hunting at their band edges, for people."""
    names = ", ".join(profile.thrusters[i].name for i in missed)
    band = "its dead band" if len(missed) == 1 else "their dead bands"
    return (f"the last hold did not show {names} hunting at the {'upper' if upward else 'lower'}"
            f" edge of {band}: the load aimed again; ")


def _aimed(latest: HoldSamples, on: Load, missed: tuple[int, ...], known: Profile,
           upward: bool, uncertainty_pct: float) -> tuple[Load, str]:
    """The load for the band hold (``upward``: the upper edges') aimed from the ``latest``
    hold, made with the load ``on`` hung, read with the calibration of ``known``; and what
    it is for, for the operator (empty load: the vehicle is there already, to the gram)."""
    fit = estimate_segment(latest, known)
    q_sd = np.sqrt(np.diag(fit.q_cov))[:3]
    loaded: FloatArray = ballast_change(known, load_change(known, on))[0]
    q = fit.q[:3] - loaded[:3]
    load = band_load(known, q, upward, q_sd)
    side, state = ("upper", "heavy") if upward else ("lower", "buoyant")
    sd = q_sd[0]
    what = "without its load " if on else ""
    text = (
        (_hunted_text(known, missed, upward) if missed else "")
        + f"the vehicle held level {what}at W − B {q[0]:+.2f} ± {sd:.2f} N, x, y net moments "
        f"{q[1]:+.2f} ± {q_sd[1]:.2f}, {q[2]:+.2f} ± {q_sd[2]:.2f} N·m; for each vertical "
        f"thruster to hunt at its {side} band edge it should be {state} at "
        f"{load.margin_N:+.2f} N, {load.aim[1]:+.2f}, {load.aim[2]:+.2f} N·m"
        + (f" (its W − B is known to ± {sd:.2f} N only, more than the band's "
           f"{abs(load.margin_N):.2f} N: the load may miss it; a calibration first, "
           "e.g. the verify hold after `trimd ballast apply`, narrows it)"
           if sd > abs(load.margin_N) else "")
        + (", the load leaving the moments {:+.3f}, {:+.3f} N·m off it".format(
            *load.miss_Nm) if max(map(abs, load.miss_Nm)) > 1e-6 else "") + ": ")
    g = known.gravity_m_s2
    hung = tuple(KnownWeight(round(f / g, 3), slot, uncertainty_pct)  # to the gram
                 for slot, f in load.pieces if round(f / g, 3))
    return hung, text
