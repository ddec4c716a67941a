"""Running the passive trim watch over a live link or a log, and what it prints and plots.

:func:`watch_link` reads a link's samples into a :class:`~trimd.core.watch.TrimWatch`
and never commands anything through it: no set-point, no mode, no MANUAL_CONTROL (a
MAVLink link still sends its heartbeat and asks for the telemetry streams it reads, as any
ground station does). A link that announces (:class:`~trimd.core.link.Announces`) gets
the alerts, the watch's state and each segment's values for the pilot's ground station
(:mod:`trimd.app.announce`). :func:`watch_log` feeds a recorded log through the
same class. Each record (:class:`~trimd.core.watch.WatchSegment`,
:class:`~trimd.core.watch.WatchAlert`) goes to ``emit`` as it completes: one JSON object
per line (``to_dict``) or a line for people (:func:`format_record`);
:func:`verdict` sums a watch up and :func:`write_watch_plot` draws it.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from trimd.app.announce import WatchAnnouncer
from trimd.core.errors import LinkError
from trimd.core.link import Announces, Link
from trimd.core.profile import Profile
from trimd.core.samples import Sample
from trimd.core.watch import (
    DEPTH_HOLD_CLASSES,
    MIN_SEGMENT_S,
    TrimWatch,
    WatchAlert,
    WatchSegment,
)
from trimd.logs.replay import ReplayLink

__all__ = ["LiveWatch", "Record", "format_record", "verdict", "watch_link", "watch_log",
           "write_watch_plot"]

Record = WatchSegment | WatchAlert


class LiveWatch:
    """A watch fed from a live link: each sample's records go to ``emit`` and, when the
    link announces (:class:`~trimd.core.link.Announces`), to the pilot's ground station
    (:class:`~trimd.app.announce.WatchAnnouncer`). Commands nothing."""

    def __init__(self, link: Link, watch: TrimWatch, emit: Callable[[Record], None]) -> None:
        self.watch = watch
        self._emit = emit
        self._announcer = (WatchAnnouncer(link.announce, watch) if isinstance(link, Announces)
                           else None)

    def feed(self, s: Sample) -> None:
        """One sample."""
        records = self.watch.feed(s)
        for record in records:
            self._emit(record)
        if self._announcer is not None:
            self._announcer.sample(s)
            self._announcer.records(records)

    def finish(self) -> None:
        """The end of the samples: the records still pending."""
        records = self.watch.finish()
        for record in records:
            self._emit(record)
        if self._announcer is not None:
            self._announcer.records(records)


async def watch_link(link: Link, watch: TrimWatch, emit: Callable[[Record], None], *,
                     until_s: float | None = None, stop: asyncio.Event | None = None) -> None:
    """Feed ``link``'s samples to ``watch`` until the link ends, ``until_s`` of sample
    time has passed since the first sample, or ``stop`` is set; then the rest. Commands
    nothing. A lost link is reported (Health) and waited for, as the vehicle may return."""
    t0 = math.nan
    live = LiveWatch(link, watch, emit)
    try:
        async for s in link.samples():
            if math.isnan(t0):
                t0 = s.t_s
            live.feed(s)
            if (until_s is not None and s.t_s - t0 >= until_s) or (
                    stop is not None and stop.is_set()):
                break
    except LinkError as exc:
        watch.notes.append(f"link ended: {exc}")
    live.finish()


def watch_log(path: str, profile: Profile, watch: TrimWatch,
              emit: Callable[[Record], None]) -> list[str]:
    """Feed every sample of the log at ``path`` to ``watch``; the log's warnings."""
    replay = ReplayLink(path, profile)
    for s in replay.read_samples():
        for record in watch.feed(s):
            emit(record)
    for record in watch.finish():
        emit(record)
    return replay.warnings


def format_record(r: Record) -> str:
    """One line for people."""
    if isinstance(r, WatchAlert):
        return f"[{r.alert.at_s:8.1f} s] ALERT: {r.text}"
    e = r.estimate
    std = e.q_std
    moments = ", ".join(f"{e.q[i]:+.3f} ± {std[i]:.3f}" if e.observable[i] else "n/a"
                        for i in (1, 2, 3))
    force = f"{e.q[0]:+.2f} ± {std[0]:.2f} N" if e.observable[0] else "n/a"
    tag = " (baseline)" if r.baseline else ""
    return (f"[{e.t_end_s:8.1f} s] {e.label}{tag}: {e.t_start_s:.1f}–{e.t_end_s:.1f} s at "
            f"roll {e.roll_deg:+.1f}°, pitch {e.pitch_deg:+.1f}°: W − B {force}; "
            f"W·r_g − B·r_b ({moments}) N·m")


def verdict(watch: TrimWatch) -> str:
    """What the watch found, or why it found nothing."""
    rejected = "; ".join(f"{n} {why}" for why, n in sorted(watch.rejected.items()))
    notes = "".join(f"\n  {n}" for n in watch.notes)
    if not watch.segments:
        return f"no steady segment: {_why_none(watch, rejected)}{notes}"
    n_base = sum(s.baseline for s in watch.segments) - len(watch.baseline_dropped)
    base = (watch.detector.baseline.source if watch.detector is not None else
            f"not formed ({n_base} of {watch.baseline_segments} level segments)")
    text = (f"{len(watch.segments)} steady segment(s); baseline {base}; "
            f"{len(watch.alerts)} alert(s)")
    if watch.alerts:
        text += "".join(f"\n  {a.text}" for a in watch.alerts)
    elif watch.detector is not None:
        text += f" (no significant change; CUSUM threshold h = {watch.h:.2f} σ)"
    if watch.segments and not watch.segments[0].estimate.observable[3]:
        text += ("\n  at level the height of the centre of gravity (W·z_g − B·z_b) is not "
                 "observable")
    if watch.baseline_dropped:
        text += ("\n  left out of the baseline, as the trim moved while it formed (a piece "
                 "lost? a sudden flood?): " + "; ".join(watch.baseline_dropped))
    if rejected:
        text += f"\n  not counted: {rejected}"
    if watch.breaks:
        text += f"\n  stretches broken by motion: {_breaks(watch)}"
    return text + notes


def _breaks(watch: TrimWatch) -> str:
    return ", ".join(f"{n} {why}" for why, n in sorted(watch.breaks.items()))


def _why_none(watch: TrimWatch, rejected: str) -> str:
    modes = ", ".join(sorted(watch.modes_seen)) or "none reported"
    if not watch.attitude_samples:
        return "no attitude in the samples"
    if not watch.thruster_samples:
        return "no thruster outputs in the samples (nothing measures the effort)"
    if not watch.counted_samples:
        held = " or ".join(sorted(c.value for c in DEPTH_HOLD_CLASSES))
        return (f"never armed in a mode that holds depth ({held}) with the depth held and "
                f"the sticks at rest; modes seen: {modes}")
    share = f"{watch.counted_samples} of {watch.attitude_samples} attitude samples"
    broken = f" between motion: {_breaks(watch)}" if watch.breaks else ""
    if rejected:
        return f"{share} counted; the steady stretches did not: {rejected}{broken}"
    return (f"{share} counted (armed in a depth-holding mode, depth held, at rest{broken}), "
            "but no stretch "
            f"had attitude and thruster effort steady for "
            f"{watch.profile.procedure.min_steady_s:g} s plus {MIN_SEGMENT_S:g} s to "
            f"collect; modes seen: {modes}")


def write_watch_plot(watch: TrimWatch, path: str | Path) -> Path:
    """A PNG of W − B and the net moments over time: each segment's estimate ± 1σ across
    its span, the baseline shaded, each alert a vertical line at its time (dashed at the
    change time it names)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # 0.7 s: only to plot
    from matplotlib.figure import Figure

    names = ("W − B [N]", "W·x_g − B·x_b [N·m]", "W·y_g − B·y_b [N·m]")
    fig = Figure(figsize=(10, 8))
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1, sharex=True)
    for i, ax in enumerate(axes):
        for s in watch.segments:
            e = s.estimate
            if not e.observable[i]:
                continue
            mid, sd = (e.t_start_s + e.t_end_s) / 2, float(np.sqrt(e.q_cov[i, i]))
            ax.errorbar(mid, e.q[i], yerr=sd, xerr=(e.t_end_s - e.t_start_s) / 2, fmt="o",
                        color="tab:green" if s.baseline else "tab:blue", ms=3)
        if watch.detector is not None and math.isfinite(watch.detector.baseline.q[i]):
            b, sd = watch.detector.baseline.q[i], math.sqrt(watch.detector.baseline.var[i])
            ax.axhspan(b - sd, b + sd, color="tab:green", alpha=0.2)
            ax.axhline(b, color="tab:green", lw=0.8)
        for a in watch.alerts:
            if a.alert.component == i:
                ax.axvline(a.alert.at_s, color="tab:red")
                ax.axvline(a.alert.since_s, color="tab:red", ls="--")
        ax.set_ylabel(names[i])
        ax.grid(True, alpha=0.3)
    axes[0].set_title(f"trim watch: {len(watch.segments)} segments (green: baseline), "
                      f"{len(watch.alerts)} alert(s) (red: raised, dashed: since)")
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=100)
    return out
