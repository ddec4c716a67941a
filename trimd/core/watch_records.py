"""What the passive trim watch reports: its segments and alerts, as records and words.

:class:`WatchSegment` (a steady segment and its estimate) and :class:`WatchAlert` (a
change alert and its text, :func:`alert_text`) are what :class:`trimd.core.watch.
TrimWatch` returns; ``to_dict`` gives each one's JSON line (docs/operator.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from trimd.core.change import ChangeAlert
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.segment import Q_NAMES, SegmentEstimate

__all__ = ["WatchAlert", "WatchSegment", "alert_text"]


@dataclass(frozen=True)
class WatchSegment:
    """A steady segment the watch found and its estimate (``index`` counts from 1);
    ``baseline`` is True while it is one of the segments forming the baseline; ``full``,
    at a tilted segment, the estimate of all four net quantities (weight and centre of
    gravity) from it and the last level segment (:func:`trimd.core.estimate.
    estimate_static`; it assumes the trim did not change between the two)."""

    index: int
    estimate: SegmentEstimate
    baseline: bool
    full: StaticEstimate | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: times [s], attitude [deg], q and its 1σ [N, N·m] (null where not
        observable), covariances, which components the segment observed."""
        e = self.estimate
        std = e.q_std
        return {"type": "segment", "index": self.index, "t_start_s": e.t_start_s,
                "t_end_s": e.t_end_s, "roll_deg": e.roll_deg, "pitch_deg": e.pitch_deg,
                "samples": e.samples, "baseline": self.baseline,
                "net_force_N": _opt(e.q[0], e.observable[0]),
                "net_force_std_N": _opt(std[0], e.observable[0]),
                "net_moment_Nm": [_opt(e.q[i], e.observable[i]) for i in (1, 2, 3)],
                "net_moment_std_Nm": [_opt(std[i], e.observable[i]) for i in (1, 2, 3)],
                "observable": list(e.observable), "resolved": e.resolved,
                "cov_net": e.q_cov.tolist(), "cov_net_noise": e.q_cov_noise.tolist(),
                "not_observable": _unobservable(e),
                "full": None if self.full is None else estimate_to_dict(self.full)}


@dataclass(frozen=True)
class WatchAlert:
    """A change alert: the test's result and its text for people."""

    alert: ChangeAlert
    text: str

    def to_dict(self) -> dict[str, Any]:
        a = self.alert
        return {"type": "alert", "quantity": _QUANTITY[a.component], "component": a.component,
                "total": a.total, "total_std": a.total_std, "change": a.change,
                "change_std": a.change_std,
                "after_s": None if math.isnan(a.after_s) else a.after_s,
                "since_s": a.since_s, "t_s": a.at_s, "segments": a.segments,
                "statistic": a.statistic, "first": a.first, "text": self.text}


_QUANTITY = ("net_force_N", "net_moment_x_Nm", "net_moment_y_Nm")
#: per component: (increase, decrease, what may cause an increase, a decrease)
_WORDS = (("heavier", "lighter", "water ingress? lost float?", "lost weight? trapped air?"),
          ("nose-heavy", "tail-heavy", "weight forward, or a float lost forward?",
           "weight aft, or a float lost aft?"),
          ("starboard-heavy", "port-heavy", "weight to starboard, or a float lost there?",
           "weight to port, or a float lost there?"))


def _opt(v: float, ok: bool) -> float | None:
    return float(v) if ok else None


def _unobservable(e: SegmentEstimate) -> str:
    if e.observable == (True, True, True, False):
        return ("level: the moment about the vertical, W·z_g − B·z_b (the height of the "
                "centre of gravity), is not observable")
    missing = [n for n, ok in zip(Q_NAMES, e.observable, strict=True) if not ok]
    return (f"at roll {e.roll_deg:.1f}°, pitch {e.pitch_deg:.1f}° one attitude cannot "
            f"separate {', '.join(missing)}" if missing else "")


def alert_text(a: ChangeAlert, clock: Callable[[float], str]) -> str:
    """E.g. "heavier by 2.1 ± 0.3 N since t = 311–345 s (water ingress? lost float?)";
    a later alert of the same quantity adds how much more since when."""
    up, down, why_up, why_down = _WORDS[a.component]
    unit = "N" if a.component == 0 else "N·m"
    word, why = (up, why_up) if a.total > 0 else (down, why_down)
    when = (f"since {clock(a.since_s)}" if math.isnan(a.after_s) or a.since_s - a.after_s < 1
            else f"since between {clock(a.after_s)} and {clock(a.since_s)}")
    text = f"{word} by {_pm(abs(a.total), a.total_std)} {unit}"
    if a.first:
        return f"{text} {when} ({why})"
    return f"{text} ({_pm(a.change, a.change_std, sign=True)} {unit} {when}) ({why})"


def _pm(value: float, std: float, sign: bool = False) -> str:
    """``value ± std`` with two significant digits of ``std`` (at least two decimals)."""
    digits = max(2, 1 - math.floor(math.log10(std))) if std > 0 else 2
    return f"{value:{'+' if sign else ''}.{digits}f} ± {std:.{digits}f}"
