"""What the watch and the trim tell the pilot's ground station (``docs/mavlink.md``,
"On the pilot's ground station").

Texts start with ``TRIMD`` and are as short as a ground station's message line:

* a watch alert at ALERT (heavier: water?) or CRITICAL (every other change), e.g.
  ``TRIMD heavier 2.4±0.1N since 5min: water?`` (:func:`alert_text`): the change
  against the baseline with its 1σ, and how long before the alert it began;
* the watch starting and its baseline at INFO;
* a trim's phases at INFO and its end at NOTICE: the estimate (W − B, extra mass), the
  verify hold's verdict, or why it failed or was aborted (:class:`RunAnnouncer`).

Values (:data:`VALUE_NAMES`) after every steady segment of the watch: the segment's
W − B [N] and net moments [N·m] that the segment observes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from trimd.app.results import AnyPresenter, Finding
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import Verification
from trimd.core.announce import Announcement, Severity, Text, Values
from trimd.core.change import ChangeAlert
from trimd.core.events import Notice, Output, Phase, Progress
from trimd.core.link import Announces, Link
from trimd.core.samples import Health, Sample
from trimd.core.watch import TrimWatch, WatchAlert, WatchSegment

__all__ = ["VALUE_NAMES", "RunAnnouncer", "WatchAnnouncer", "alert_text", "announce_run",
           "segment_values"]

Announce = Callable[[Announcement], None]

#: NAMED_VALUE_FLOAT names of q's components: W − B [N] (positive: heavier than it
#: floats), W·x_g − B·x_b (positive: nose-heavy), W·y_g − B·y_b (positive: starboard-heavy)
#: and W·z_g − B·z_b [N·m] (only from a tilted segment).
VALUE_NAMES = ("TRIMD_WB", "TRIMD_MX", "TRIMD_MY", "TRIMD_MZ")
#: per component: (increase, decrease, what may cause an increase, a decrease)
_WORDS = (("heavier", "lighter", "water?", "lost weight?"),
          ("nose-heavy", "tail-heavy", "weight fwd?", "weight aft?"),
          ("stbd-heavy", "port-heavy", "weight stbd?", "weight port?"))


def _pm(value: float, std: float) -> str:
    """``value±std`` to the first significant digit of ``std``."""
    digits = max(0, -math.floor(math.log10(std))) if std > 0 and math.isfinite(std) else 2
    return f"{value:.{digits}f}±{std:.{digits}f}"


def _age(seconds: float) -> str:
    """A duration for people: ``40s``, ``5min``, ``2.5h``."""
    if seconds < 90:
        return f"{max(seconds, 0):.0f}s"
    if seconds < 5400:
        return f"{seconds / 60:.0f}min"
    return f"{seconds / 3600:.1f}h"


def alert_text(a: ChangeAlert) -> Text:
    """The alert for the ground station (ALERT when heavier, else CRITICAL).

    Examples
    --------
    >>> a = ChangeAlert(0, 2.43, 0.13, 2.43, 0.13, 290.0, 310.0, 621.0, 3, 9.1, True)
    >>> t = alert_text(a)
    >>> t.severity.name, t.text
    ('ALERT', 'TRIMD heavier 2.4±0.1N since 5min: water?')
    """
    up, down, why_up, why_down = _WORDS[a.component]
    word, why = (up, why_up) if a.total > 0 else (down, why_down)
    unit = "N" if a.component == 0 else "Nm"
    severity = Severity.ALERT if a.component == 0 and a.total > 0 else Severity.CRITICAL
    return Text(severity, f"TRIMD {word} {_pm(abs(a.total), a.total_std)}{unit} since "
                          f"{_age(a.at_s - a.since_s)}: {why}")


def segment_values(segment: WatchSegment) -> Values:
    """The segment's net quantities that it observes, by :data:`VALUE_NAMES`."""
    e = segment.estimate
    return Values(tuple((name, float(e.q[i])) for i, name in enumerate(VALUE_NAMES)
                        if e.observable[i]))


class WatchAnnouncer:
    """Turns a watch's samples and records into announcements for ``announce``."""

    def __init__(self, announce: Announce, watch: TrimWatch) -> None:
        self.announce = announce
        self.watch = watch
        self._started = False
        self._had_baseline = watch.detector is not None

    def sample(self, s: Sample) -> None:
        """The vehicle's first heartbeat: the watch says it is on."""
        if self._started or not (isinstance(s, Health) and s.connected):
            return
        self._started = True
        base = ("baseline given" if self._had_baseline else
                f"baseline after {self.watch.baseline_segments} hovers")
        self.announce(Text(Severity.INFO, f"TRIMD watch on: {base}"))

    def records(self, records: Sequence[WatchSegment | WatchAlert]) -> None:
        """Values for each segment, a text for each alert and for a baseline just formed."""
        for r in records:
            if isinstance(r, WatchSegment):
                self.announce(segment_values(r))
            else:
                self.announce(alert_text(r.alert))
        detector = self.watch.detector
        if detector is not None and not self._had_baseline:
            self._had_baseline = True
            q, sd = detector.baseline.q[0], math.sqrt(detector.baseline.var[0])
            self.announce(Text(Severity.INFO, f"TRIMD watch baseline W-B {_pm(q, sd)}N"))


def _verdict(notice: Notice[Proposal, Finding]) -> str | None:
    """The end of a trim or verify hold in a few words (None: not a result)."""
    if notice.result is not None:
        est, proposal = notice.result.estimate, notice.result.proposal
        text = (f"TRIMD trim done: W-B {_pm(float(est.q[0]), float(math.sqrt(est.q_cov[0, 0])))}"
                f"N, m_ext {_pm(est.m_ext_kg, est.m_ext_std_kg)}kg")
        if proposal is not None:
            text += ", ballast proposed" if proposal.feasible else ", no feasible ballast"
        return text
    v = notice.verification
    if isinstance(v, Verification):
        level = "level" if v.level else f"NOT level within {v.level_tol_deg:g}°"
        return f"TRIMD verify: {level}, {'as' if v.as_predicted else 'NOT as'} predicted"
    return None


class RunAnnouncer:
    """A session presenter (:class:`trimd.app.session.Presenter`) that announces a
    trim's phases at INFO and how it ended at NOTICE."""

    def __init__(self, announce: Announce) -> None:
        self.announce = announce

    def output(self, out: Output[Proposal, Finding], progress: Progress) -> None:
        if not isinstance(out, Notice):
            return
        verdict = _verdict(out)
        if verdict is not None:
            self.announce(Text(Severity.NOTICE, verdict))
        elif out.kind == "state" and out.phase in (Phase.FAILED, Phase.ABORTED):
            self.announce(Text(Severity.NOTICE, f"TRIMD trim {out.phase.value}: {out.text}"))
        elif out.kind == "state" and out.phase not in (None, Phase.CONNECT, Phase.DONE):
            self.announce(Text(Severity.INFO, f"TRIMD {out.text}"))

    def sample(self, sample: Sample, progress: Progress) -> None:
        return None


def announce_run(link: Link, presenters: list[AnyPresenter]) -> None:
    """Add a :class:`RunAnnouncer` to a session's ``presenters`` when ``link`` announces."""
    if isinstance(link, Announces):
        presenters.append(RunAnnouncer(link.announce))
