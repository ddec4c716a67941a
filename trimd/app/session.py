"""One trim session: a link, the recorder, the procedure and a presenter, wired together.

The session is the only place where the procedure meets I/O. It

* starts at the vehicle's first heartbeat (a Health sample), puts every sample on the
  session time base (seconds since then, to the millisecond) and passes it through the
  recorder, so the procedure sees exactly what a replay of the log will see;
* feeds the procedure samples, operator events (a recording's :class:`Confirmed` is the
  operator's confirmation, where it took effect live) and, when a live link goes quiet, Ticks
  from the monotonic clock (so a dead link still times out; a recording has its own
  clock only); a vehicle that talks but never connects (a link's disconnected Health:
  another protocol version, no answer to the handshake) fails after
  ``connect_timeout_s`` with the link's reason;
* sends the procedure's commands, records them (stamped with the session time of the
  sample or Tick that caused them), and hands notices and progress to the
  presenter (each presenter failure is logged, never fatal). A command is delivered in a
  task of its own: a link that waits for the vehicle to confirm a mode change (MAVLink,
  up to 3 s) never holds up an abort or the samples behind it;
* always releases the vehicle and closes the log on the way out (done, failure,
  operator abort, signal or internal error).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import time
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import dataclass
from typing import Generic, Protocol, TypeVar

from trimd.core.errors import LinkError
from trimd.core.estimate import HoldSamples, StaticEstimate, is_level
from trimd.core.events import (
    Abort,
    Cause,
    Confirm,
    Event,
    Notice,
    Output,
    P,
    Phase,
    Progress,
    Tick,
    V,
)
from trimd.core.link import Link, RawPackets
from trimd.core.procedure import Procedure
from trimd.core.profile import Profile
from trimd.core.samples import Command, Confirmed, Health, PilotInput, Release, Sample

__all__ = ["Machine", "Presenter", "Recorder", "Session", "SessionResult"]

log = logging.getLogger(__name__)

#: What a presenter can take: a result's proposal and finding (contravariant).
P_in = TypeVar("P_in", contravariant=True)
V_in = TypeVar("V_in", contravariant=True)
#: A session's proposal and finding: its machine's result types, its presenters' at least.
PT = TypeVar("PT")
VT = TypeVar("VT")

#: With no sample for this long [s, wall clock], the session ticks the procedure: a link
#: silent for the profile's ``link_timeout_s`` is released at most this much later.
TICK_S = 0.1
#: On the way out, how long [s, wall clock] the session waits for the link to take the
#: last commands (the release) before it closes the link.
DELIVERY_WAIT_S = 3.0


class Recorder(Protocol):
    """Where a session writes everything; ``sample`` returns the sample *as recorded*,
    ``raw`` takes a packet exactly as a MAVLink link received it."""

    path: str

    def sample(self, sample: Sample) -> Sample: ...

    def raw(self, t_s: float, packet: bytes) -> None: ...

    def command(self, t_s: float, command: Command) -> None: ...

    def notice(self, notice: Notice[object, object]) -> None: ...

    def flush_due(self) -> None:
        """Push what is written to the disk if it has waited a second or more."""
        ...

    def close(self) -> None: ...


class Presenter(Protocol[P_in, V_in]):
    """A consumer of the session's outputs (headless printer, TUI)."""

    def output(self, out: Output[P_in, V_in], progress: Progress) -> None: ...

    def sample(self, sample: Sample, progress: Progress) -> None: ...


class Machine(Protocol[P, V]):
    """A state machine a session runs: the trim :class:`Procedure`, or an excitation
    experiment (:class:`trimd.identify.experiment.Excite`)."""

    profile: Profile
    phase: Phase
    reason: str
    cause: Cause

    @property
    def estimate(self) -> StaticEstimate | None: ...

    @property
    def proposal(self) -> P | None: ...

    @property
    def verification(self) -> V | None: ...

    @property
    def progress(self) -> Progress: ...

    def step(self, event: Event) -> Sequence[Output[P, V]]: ...


@dataclass(frozen=True)
class SessionResult(Generic[P, V]):
    """How the session ended (``cause`` as :attr:`Procedure.cause`), its estimate and
    proposal (when done), the log path, a verify hold's verification, and the samples of
    its first hold when that was level (a calibration experiment's half:
    :mod:`trimd.app.history.calibration`)."""

    phase: Phase
    reason: str
    cause: Cause
    estimate: StaticEstimate | None
    proposal: P | None
    log_path: str | None
    verification: V | None = None
    level_hold: HoldSamples | None = None


class Session(Generic[PT, VT]):
    """Run the trim procedure over ``link`` until it is done, fails or is aborted."""

    def __init__(self, link: Link, profile: Profile, *, recorder: Recorder | None,
                 presenters: Sequence[Presenter[PT, VT]], confirmed: bool = False,
                 propose: Callable[[StaticEstimate], PT] | None = None,
                 procedure: Machine[PT, VT] | None = None, wall_clock: bool = True) -> None:
        """``procedure`` defaults to the trim :class:`Procedure`; any object with the same
        ``step``/``progress``/``phase``/``reason``/``cause``/``estimate``/``proposal``
        (e.g. an excitation experiment) runs the same way.

        ``wall_clock=False`` is for a recording: time is the samples' alone, so no Ticks
        (and no connect timeout) come from the monotonic clock; a paused or slowed replay
        then times nothing out, and any pace gives the live result (the live session
        recorded no Ticks either)."""
        self.link = link
        self.wall_clock = wall_clock
        self.recorder = recorder
        self.presenters: list[Presenter[PT, VT]] = list(presenters)
        self.procedure: Machine[PT, VT] = procedure or Procedure(profile, confirmed=confirmed,
                                                         propose=propose)
        self._operator: asyncio.Queue[Event] = asyncio.Queue()
        self._t0: float | None = None
        self._t_last = 0.0
        self._t_now = 0.0  # the latest sample's or Tick's session time: commands' stamp
        self._wall_last = time.monotonic()
        self._commanded = False
        self._deliveries: set[asyncio.Future[None]] = set()
        # a MAVLink link hands over every packet as received: record those, not re-encoded
        # samples (the packets decode to the very samples the link yields)
        self._raw = recorder is not None and isinstance(link, RawPackets)
        if isinstance(link, RawPackets) and recorder is not None:
            link.on_raw = self._on_raw

    def add_presenter(self, presenter: Presenter[PT, VT]) -> None:
        """Hand the outputs from now on to ``presenter`` too (e.g. one that needs the
        session: :class:`trimd.app.headless.StdinConfirm`)."""
        self.presenters.append(presenter)

    def confirm(self) -> None:
        """The operator allows commanding the vehicle."""
        self._operator.put_nowait(Confirm())

    def abort(self, reason: str = "aborted by the operator") -> None:
        """Stop: the procedure releases the vehicle at once."""
        self._operator.put_nowait(Abort(reason))

    async def run(self) -> SessionResult[PT, VT]:
        try:
            await self._loop()
        except Exception as exc:
            log.exception("session failed")
            await self._feed(Abort(f"internal error: {type(exc).__name__}: {exc}"))
        finally:
            if self._commanded and not self.procedure.phase.final:
                await self._feed(Abort("session ended"))
            await self._release_if_needed()
            with contextlib.suppress(Exception):
                await self.link.close()
            if self.recorder is not None:
                self.recorder.close()
        p = self.procedure
        holds = p.hold_samples()[:1] if isinstance(p, Procedure) else []
        return SessionResult(p.phase, p.reason, p.cause, p.estimate, p.proposal,
                             self.recorder.path if self.recorder else None,
                             p.verification,
                             holds[0] if holds and is_level(holds[0]) else None)

    async def _loop(self) -> None:
        samples: AsyncIterator[Sample] = self.link.samples()
        next_sample = asyncio.ensure_future(anext(samples))
        next_operator = asyncio.ensure_future(self._operator.get())
        started = time.monotonic()
        connect_timeout = self.procedure.profile.procedure.connect_timeout_s
        waiting = ""
        self._say(Notice(0.0, "state", f"waiting for the vehicle on "
                         f"{getattr(self.link, 'description', 'the link')}", Phase.CONNECT))
        try:
            while not self.procedure.phase.final:
                done, _ = await asyncio.wait({next_sample, next_operator}, timeout=TICK_S,
                                             return_when=asyncio.FIRST_COMPLETED)
                if next_operator in done:
                    await self._feed(next_operator.result())
                    next_operator = asyncio.ensure_future(self._operator.get())
                if next_sample in done:
                    try:
                        sample = next_sample.result()
                    except (StopAsyncIteration, LinkError) as exc:
                        detail = str(exc) or "the link closed"
                        await self._feed(Health(self._t_last, False, "", False, detail=detail))
                        break
                    next_sample = asyncio.ensure_future(anext(samples))
                    if isinstance(sample, Confirmed):  # a recording: confirmed here, live
                        await self._feed(Confirm())
                    elif self._t0 is not None or (isinstance(sample, Health)
                                                  and sample.connected):
                        await self._feed(self._on_session_time(sample))
                    elif isinstance(sample, Health) and sample.detail:
                        waiting = sample.detail  # why the link does not connect (yet)
                if not self.wall_clock:
                    continue
                if self._t0 is None:
                    # the session starts with the vehicle's first heartbeat; a vehicle that
                    # talks but never connects (wrong protocol, no handshake) times out too
                    if time.monotonic() - started > connect_timeout:
                        await self._feed(Health(0.0, False, "", False, detail=(
                            f"the vehicle did not connect within {connect_timeout:g} s: "
                            f"{waiting}" if waiting else
                            f"no heartbeat from the vehicle within {connect_timeout:g} s")))
                elif not done:
                    # session time runs from the first heartbeat: no Tick before it (a
                    # replay has none either)
                    await self._feed(Tick(self._t_last + time.monotonic() - self._wall_last))
                    if self.recorder:  # a quiet link: what came last reaches the disk too
                        self.recorder.flush_due()
        finally:
            for task in (next_sample, next_operator):
                task.cancel()
            with contextlib.suppress(BaseException):
                await asyncio.gather(next_sample, next_operator, return_exceptions=True)

    def _session_time(self, t_s: float) -> float:
        """Seconds since the first heartbeat, to the millisecond (0 before it)."""
        if self._t0 is None:
            return 0.0
        return max(round((t_s - self._t0) * 1000.0) / 1000.0, self._t_last)

    def _on_raw(self, t_s: float, packet: bytes) -> None:
        if self.recorder is not None:
            self.recorder.raw(self._session_time(t_s), packet)

    def _on_session_time(self, sample: Sample) -> Sample:
        if self._t0 is None:
            self._t0 = sample.t_s
        s = dataclasses.replace(sample, t_s=self._session_time(sample.t_s))
        self._t_last, self._wall_last = s.t_s, time.monotonic()
        self._t_now = max(self._t_now, s.t_s)
        # a raw link's packets are its samples, except what the link concludes itself
        # (someone else took over): no packet says that, so it is recorded as a sample
        packet = self._raw and not isinstance(s, PilotInput)
        recorded = s if packet or self.recorder is None else self.recorder.sample(s)
        for presenter in self.presenters:
            self._safely(presenter.sample, recorded, self.procedure.progress)
        return recorded

    async def _feed(self, event: Event) -> None:
        if isinstance(event, Tick):
            self._t_now = max(self._t_now, event.t_s)
        for out in self.procedure.step(event):
            if isinstance(out, Notice):
                self._say(out)
            else:
                self._send(out)
                for presenter in self.presenters:
                    self._safely(presenter.output, out, self.procedure.progress)

    def _say(self, notice: Notice[PT, VT]) -> None:
        """Record ``notice`` and hand it to the presenters."""
        if self.recorder:
            self.recorder.notice(notice)
        for presenter in self.presenters:
            self._safely(presenter.output, notice, self.procedure.progress)

    def _send(self, command: Command) -> None:
        """Record ``command`` and start delivering it (commands leave in order)."""
        if self.recorder:
            self.recorder.command(self._t_now, command)
        self._commanded = not isinstance(command, Release)
        delivery = asyncio.ensure_future(self._deliver(command))
        self._deliveries.add(delivery)
        delivery.add_done_callback(self._deliveries.discard)

    async def _deliver(self, command: Command) -> None:
        try:
            await self.link.send(command)
        except LinkError as exc:
            log.error("could not send %s: %s", command, exc)
            if not isinstance(command, Release):
                self.abort(f"link error while commanding: {exc}")

    async def _release_if_needed(self) -> None:
        """Release if trimd still commands, then let the link take what is under way."""
        if self._commanded:
            self._send(Release())
        if self._deliveries:
            await asyncio.wait(self._deliveries, timeout=DELIVERY_WAIT_S)

    @staticmethod
    def _safely(fn: Callable[..., None], *args: object) -> None:
        try:
            fn(*args)
        except Exception:
            log.exception("presenter %r failed", fn)
