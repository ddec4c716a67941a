"""``trimd serve``'s service loop: the passive watch kept running on a vehicle, dive after dive.

:class:`Service` opens the link, follows the vehicle's Health and treats each stretch
armed and connected as a *dive*: a fresh :class:`~trimd.core.watch.TrimWatch` (from
``new_watch``), a recording of the dive's samples (``<data>/dives/<id>-<vehicle>.tlog``,
replayable with ``trimd watch FILE``) and every segment and alert stored in the trim
history the moment it completes, each with the dive's ``id``. A dive ends when the vehicle
disarms, its heartbeat stops (an autopilot reboot) or the link fails; a failed link is
opened again after :data:`RETRY_S`. The watch stays passive: nothing is sent but what a
MAVLink link sends any ground station, and the watch's announcements
(:class:`~trimd.app.watch.LiveWatch`).

Dive time: the samples a dive's watch sees, and its recording, are timed from the dive's
first sample [s]; alert texts name times as UTC wall-clock time (the dive's start plus that
time, so with a simulator faster than real time they run ahead of the wall clock).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import math
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from trimd.app.connect import open_link, parse_link_url
from trimd.app.history import History
from trimd.app.watch import LiveWatch, Record
from trimd.core.errors import DataError, LinkError
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.samples import Health, Sample
from trimd.core.watch import TrimWatch, WatchAlert
from trimd.logs.recorder import TlogRecorder

__all__ = ["DEFAULT_PORT", "RETRY_S", "Dive", "Service", "dive_clock", "dive_id"]

#: The HTTP port (BlueOS's extensions take ports of their own; 8970 is not one of
#: BlueOS's services').
DEFAULT_PORT = 8970

#: Wait before opening a failed link again [s, wall clock].
RETRY_S = 2.0

Clock = Callable[[float], str]


def dive_id(t_unix: float) -> str:
    """A dive's id: its start as ``YYYYmmddTHHMMSS.mmmZ`` (UTC, to the millisecond).

    Examples
    --------
    >>> dive_id(1795732920.9129)
    '20261126T224200.912Z'
    """
    return datetime.fromtimestamp(t_unix, UTC).strftime("%Y%m%dT%H%M%S.%f")[:-3] + "Z"


@dataclass
class Dive:
    """One dive: its id, start [s since the Unix epoch], watch, recording (its path, and
    its recorder while it records), first sample time [s, the link's clock] and dive time
    of the latest sample [s]; ``ended_unix`` once it is over."""

    id: str
    started_unix: float
    watch: LiveWatch
    recording: Path
    recorder: TlogRecorder | None
    t0_s: float
    duration_s: float = 0.0
    ended_unix: float | None = None


def dive_clock(started_unix: float) -> Clock:
    """Dive time [s] as UTC wall-clock text, for a dive that started at ``started_unix``."""
    return lambda t_s: datetime.fromtimestamp(started_unix + t_s, UTC).strftime("%H:%M:%S UTC")


class Service:
    """The service's state (read by the web pages) and its loop (:meth:`run`).

    ``new_watch(clock)`` makes each dive's watch; ``profile_yaml`` rides along in each
    recording; ``rate`` paces a simulated vehicle (simulated seconds per wall second;
    None: as fast as it goes); ``log`` takes a line for people."""

    def __init__(self, url: str, profile: Profile, profile_yaml: str, data: Path,
                 history: History, vehicle: str, new_watch: Callable[[Clock], TrimWatch], *,
                 rate: float | None = None, log: Callable[[str], None] = print) -> None:
        self.url, self.profile, self.data = url, profile, data
        self.history, self.vehicle = history, vehicle
        self.scheme = parse_link_url(url)[0]
        if self.scheme == "replay":
            raise LinkError("trimd serve follows a live vehicle: for a log use trimd watch LOG")
        self._profile_yaml = profile_yaml
        self._new_watch = new_watch
        self._rate = rate
        self._log = log
        self.started_unix = time.time()
        #: the link as it describes itself, its last Health, why it last failed ("": never)
        self.link_description = ""
        self.health: Health | None = None
        self.link_error = ""
        self.dive: Dive | None = None
        #: dives ended since the service started, oldest first
        self.past: list[Dive] = []
        #: history writes that failed, for people (the watch goes on without them)
        self.store_errors = 0

    # ------------------------------------------------------------------ the loop
    async def run(self, stop: asyncio.Event) -> None:
        """Follow the vehicle until ``stop`` is set, opening the link again whenever it
        fails. A simulated vehicle that cannot be opened is an error (LinkError): its
        options are wrong and will stay wrong."""
        while not stop.is_set():
            try:
                link = await open_link(self.url, self.profile)
            except LinkError as exc:
                if self.scheme == "sim":
                    raise
                self._failed(str(exc))
            else:
                self.link_description, self.link_error = link.description, ""
                self._log(f"link open: {link.description}")
                try:
                    await self._follow(link, stop)
                except LinkError as exc:
                    self._failed(str(exc))
                finally:
                    self._end_dive("link closed")
                    await link.close()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), RETRY_S)

    def _failed(self, why: str) -> None:
        self.link_error = why
        self._log(f"link error: {why} (trying again in {RETRY_S:g} s)")

    async def _follow(self, link: Link, stop: asyncio.Event) -> None:
        """``link``'s samples until ``stop`` is set (even while the link is quiet);
        LinkError when the link fails or ends."""
        follow = asyncio.ensure_future(self._consume(link))
        stopped = asyncio.ensure_future(stop.wait())
        done, _ = await asyncio.wait({follow, stopped}, return_when=asyncio.FIRST_COMPLETED)
        for task in (follow, stopped):
            task.cancel()
        await asyncio.gather(follow, stopped, return_exceptions=True)
        if follow in done:
            follow.result()

    async def _consume(self, link: Link) -> None:
        async for s in self._paced(link.samples()):
            self.sample(link, s)
        raise LinkError("the link ended")

    async def _paced(self, samples: AsyncIterator[Sample]) -> AsyncIterator[Sample]:
        """``samples``, a simulated vehicle's held back to ``rate`` times the wall clock."""
        if self.scheme != "sim" or self._rate is None:
            async for s in samples:
                yield s
            return
        t_sim0, t_wall0 = math.nan, time.monotonic()
        async for s in samples:
            if math.isnan(t_sim0):
                t_sim0 = s.t_s
            ahead = t_wall0 + (s.t_s - t_sim0) / self._rate - time.monotonic()
            if ahead > 0:
                await asyncio.sleep(ahead)
            yield s

    # ------------------------------------------------------------------ dives
    def sample(self, link: Link, s: Sample) -> None:
        """One sample of ``link``: a dive starts when the vehicle is armed and connected,
        ends when it is not."""
        if isinstance(s, Health):
            self.health = s
            diving = s.connected and s.armed
            if diving and self.dive is None:
                self._start_dive(link, s.t_s)
            elif not diving and self.dive is not None:
                self._end_dive("disarmed" if s.connected else "heartbeat lost")
        dive = self.dive
        if dive is not None:
            dive.duration_s = s.t_s - dive.t0_s
            dive.watch.feed(self._record(dive, dataclasses.replace(s, t_s=dive.duration_s)))

    def _record(self, dive: Dive, s: Sample) -> Sample:
        """``s`` written to the dive's recording, as stored; a recording the disk refuses
        stops (told once) and the watch goes on."""
        if dive.recorder is None:
            return s
        try:
            return dive.recorder.sample(s)
        except OSError as exc:
            self._log(f"warning: dive {dive.id}: recording stopped ({exc}); the watch goes on")
            with contextlib.suppress(OSError):
                dive.recorder.close()
            dive.recorder = None
            return s

    def _start_dive(self, link: Link, t_s: float) -> None:
        now = time.time()
        ident = dive_id(now)
        path = self.data / "dives" / f"{ident}-{_safe(self.vehicle)}.tlog"
        watch = LiveWatch(link, self._new_watch(dive_clock(now)), self._store)
        try:
            recorder: TlogRecorder | None = TlogRecorder(path, self.profile, self._profile_yaml)
            self._log(f"dive {ident} started: recording {path}")
        except OSError as exc:
            recorder = None
            self._log(f"warning: dive {ident} started, not recorded: {exc}")
        self.dive = Dive(ident, now, watch, path, recorder, t_s)

    def _end_dive(self, why: str) -> None:
        dive = self.dive
        if dive is None:
            return
        dive.watch.finish()
        if dive.recorder is not None:
            with contextlib.suppress(OSError):
                dive.recorder.close()
        dive.ended_unix = time.time()
        self.past.append(dive)
        self.dive = None
        w = dive.watch.watch
        self._log(f"dive {dive.id} ended ({why}): {len(w.segments)} segment(s), "
                  f"{len(w.alerts)} alert(s)")

    def _store(self, r: Record) -> None:
        """Store ``r`` under the current dive at once (a failed write is counted and told)."""
        assert self.dive is not None
        if isinstance(r, WatchAlert):
            self._log(f"ALERT: {r.text}")
        try:
            self.history.record_watch(self.vehicle, time.time(), {**r.to_dict(),
                                                                  "dive": self.dive.id})
        except DataError as exc:
            self.store_errors += 1
            self._log(f"warning: not stored in the history: {exc}")


def _safe(name: str) -> str:
    """``name`` for a file name: letters, digits, ``-`` and ``_`` kept, the rest ``_``."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)
