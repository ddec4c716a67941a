"""``trimd watch --baseline last``: the vehicle's latest measurement in its trim history.

That is the newest of its last trim (the estimate, as measured) and its last verify hold
with a measurement (W − B and the x/y net moments of the vehicle with its ballast
installed; the z moment, not observable at level, is left out). After ``ballast apply`` and
a verify hold the baseline is thus the ballasted vehicle, not the trim measured before the
ballast went on. Ballast recorded after the measurement chosen is reported: the baseline
then predates what is on the vehicle now. Units: N, N·m; 1σ stored, variances used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trimd.app.history.report import utc_text
from trimd.app.history.store import EventRecord, History
from trimd.core.change import Baseline, baseline_from_estimate
from trimd.core.errors import DataError
from trimd.core.estimate_json import estimate_from_dict

__all__ = ["LatestBaseline", "latest_baseline"]


@dataclass(frozen=True)
class LatestBaseline:
    """The baseline, which record it is (``kind``: ``trim`` or ``verify``) and a warning
    for people ("" when none)."""

    baseline: Baseline
    kind: str
    warning: str


def _measured(r: EventRecord) -> tuple[list[float], list[float]] | None:
    """A verify record's measured W − B, m_x, m_y and their 1σ; None when it has none."""
    q, sd = r.values.get("measured_N_Nm"), r.values.get("measured_std_N_Nm")
    ok = (isinstance(q, list) and isinstance(sd, list) and len(q) == len(sd) == 3
          and all(isinstance(x, int | float) for x in [*q, *sd]))
    return (q, sd) if ok else None  # type: ignore[return-value]


def latest_baseline(history: History, vehicle: str) -> LatestBaseline:
    """The vehicle's latest measurement as the watch's baseline (module docstring).
    DataError when the history holds neither a trim nor a measured verify hold for it."""
    trims = history.trims(vehicle)
    verifies = [(r, m) for r in history.verifications(vehicle)
                if (m := _measured(r)) is not None]
    trim = trims[-1] if trims else None
    verify = verifies[-1] if verifies else None
    if trim is None and verify is None:
        raise DataError(f"--baseline last: no trim or verify hold of vehicle {vehicle} in "
                        f"{history.path}")
    if verify is not None and (trim is None or verify[0].t_unix >= trim.t_unix):
        record, (q, sd) = verify
        t, kind = record.t_unix, "verify"
        baseline = Baseline(np.r_[q, np.nan], np.r_[np.square(sd), np.inf], None,
                            f"the verify hold of {vehicle} at {utc_text(t)} (the vehicle "
                            "as ballasted)")
    else:
        assert trim is not None
        t, kind = trim.t_unix, "trim"
        baseline = baseline_from_estimate(
            estimate_from_dict(trim.estimate, str(history.path)),
            f"the last trim of {vehicle} at {utc_text(t)}")
    later = [i for i in history.installs(vehicle) if i.t_unix > t]
    warning = (f"ballast was recorded for {vehicle} at {utc_text(later[-1].t_unix)}, after "
               f"{baseline.source}: the baseline may not be the vehicle as it is now (run "
               "a verify hold: trimd run --verify)" if later else "")
    return LatestBaseline(baseline, kind, warning)
