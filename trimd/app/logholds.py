"""The steady attitude holds of a vehicle log, found as the live procedure finds them.

One detector (:mod:`trimd.core.holdfinder`: the log's attitude plateaus with the live
settling test, docs/method.md "Steady state") for every view of a log: ``trimd inspect``
lists these holds and ``trimd replay`` of a foreign log lists and estimates from the
same ones. Only attitude samples taken while the vehicle was armed (or the log does not
say) in a mode that holds attitude count; all of them when the log reports no mode.
Each thruster's thrust rides along (the thrust curves' share of the ±).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from trimd.core.effort import thrust_at
from trimd.core.errors import DataError
from trimd.core.holdfinder import FoundHold, locate_holds
from trimd.core.model import thrust_configuration
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Battery, Health, ModeClass, Sample, Thrusters

__all__ = ["HOLD_CLASSES", "format_hold", "hold_to_dict", "log_holds"]

#: Mode classes in which the autopilot holds an attitude.
HOLD_CLASSES = frozenset({ModeClass.STABILISED, ModeClass.DEPTH_HOLDING,
                          ModeClass.AUTONOMOUS})


def _holding(samples: Sequence[Sample]) -> tuple[list[Attitude], list[str]]:
    """The attitude samples taken while armed (or arming not logged) in a mode that
    holds attitude (all of them when the log reports no state), and the modes seen."""
    state: Health | None = None
    seen = any(isinstance(s, Health) for s in samples)
    modes: list[str] = []
    out = []
    for s in samples:
        if isinstance(s, Health):
            state = s
            if s.mode not in modes:
                modes.append(s.mode)
        elif isinstance(s, Attitude) and (not seen or (
                state is not None and state.mode_class in HOLD_CLASSES
                and state.armed is not False)):
            out.append(s)
    return out, modes


def log_holds(samples: Sequence[Sample], profile: Profile) -> list[FoundHold]:
    """The steady holds in a log's ``samples`` (file order), labelled ``hold 1``, … as
    :func:`trimd.core.holdfinder.find_holds` labels them; DataError saying why when there
    is none."""
    thr = [s for s in samples if isinstance(s, Thrusters)]
    if not thr:
        raise DataError("no outputs of the profile's thrusters in the log (nothing measures "
                        "the effort)")
    att, modes = _holding(samples)
    if not att:
        held = ", ".join(sorted(c.value for c in HOLD_CLASSES))
        raise DataError(f"never armed in a mode that holds attitude ({held}); modes seen: "
                        f"{', '.join(modes) or 'none'}")
    t = np.array([s.t_s for s in thr])
    thrust, ok, outputs = thrust_at(profile, t, thr,
                                    [s for s in samples if isinstance(s, Battery)])
    tau = thrust[ok] @ thrust_configuration(profile.thrusters).T
    found = locate_holds(att, t[ok], tau, profile, thrust[ok], outputs.take(ok))
    if not found:
        proc = profile.procedure
        raise DataError(f"no attitude plateau settled: each needs {proc.min_steady_s:g} s "
                        f"within {proc.attitude_tol_deg:g}° with steady thruster effort, "
                        "then samples to collect")
    return found


def hold_to_dict(h: FoundHold) -> dict[str, Any]:
    """JSON-ready: label, mean roll and pitch [deg], samples, the first and last sample
    time [s] (``steady_window_s``, as an estimate's holds) and each plateau's."""
    s = h.samples
    return {"label": s.label, "roll_deg": math.degrees(float(np.mean(s.phi))),
            "pitch_deg": math.degrees(float(np.mean(s.theta))), "samples": len(s.t_s),
            "steady_window_s": [float(s.t_s[0]), float(s.t_s[-1])],
            "plateaus_s": [list(p) for p in h.plateaus_s]}


def format_hold(h: dict[str, Any]) -> str:
    """One line for people from :func:`hold_to_dict`."""
    spans = ", ".join(f"{a:.1f}–{b:.1f} s" for a, b in h["plateaus_s"])
    return (f"{h['label']}: roll {h['roll_deg']:.2f}°, pitch {h['pitch_deg']:.2f}°, "
            f"{h['samples']} samples in {spans}")
