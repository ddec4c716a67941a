"""A recording replayed in the TUI: paced against the wall clock at a speed the operator
changes, and paused, without changing what the procedure sees.

:class:`PacedReplay` wraps a :class:`trimd.logs.replay.ReplayLink` read as fast as possible and
holds each sample back until it is due at the present speed. Pausing or changing speed
re-anchors the pacing at the next sample, so the samples keep their own times: the
procedure (which runs on sample time) gives the same result at any pace.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from collections.abc import AsyncIterator

from trimd.core.samples import Command, Sample
from trimd.logs.replay import ReplayLink

__all__ = ["SPEEDS", "PacedReplay"]

#: The speeds the operator steps through [× real time]; inf: as fast as possible.
SPEEDS: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, math.inf)


class PacedReplay:
    """The Link protocol over ``link`` at ``speed`` × real time (inf: as fast as possible).

    Attributes
    ----------
    speed : the present speed [× real time].
    paused : no sample is passed on while True.
    t_s : the time of the last sample passed on [s, the recording's clock]; NaN before.
    """

    def __init__(self, link: ReplayLink, *, speed: float) -> None:
        if not speed > 0:
            raise ValueError(f"the replay speed must be positive, got {speed}")
        self.link = link
        self.description = link.description
        self.speed = speed
        self.paused = False
        self.t_s = math.nan
        self._changed = asyncio.Event()
        #: (wall clock [s], sample time [s]) the pacing counts from; None: the next sample
        self._anchor: tuple[float, float] | None = None

    @property
    def label(self) -> str:
        """``paused``, ``fast`` or the speed, e.g. ``2×``."""
        if self.paused:
            return "paused"
        return "fast" if math.isinf(self.speed) else f"{self.speed:g}×"

    def toggle_pause(self) -> None:
        """Pause, or resume at the present speed."""
        self.paused = not self.paused
        self._reanchor()

    def faster(self) -> None:
        """The next speed of :data:`SPEEDS` up (as fast as possible at the top)."""
        self.speed = next((s for s in SPEEDS if s > self.speed), SPEEDS[-1])
        self._reanchor()

    def slower(self) -> None:
        """The next speed of :data:`SPEEDS` down (the slowest at the bottom)."""
        self.speed = next((s for s in reversed(SPEEDS) if s < self.speed), SPEEDS[0])
        self._reanchor()

    def _reanchor(self) -> None:
        self._anchor = None
        self._changed.set()

    async def samples(self) -> AsyncIterator[Sample]:
        """The recording's samples, each once it is due."""
        async for sample in self.link.samples():
            await self._due(sample.t_s)
            self.t_s = sample.t_s
            yield sample

    async def _due(self, t_s: float) -> None:
        """Return when the sample of time ``t_s`` is due (waking early on any change)."""
        while True:
            self._changed.clear()
            delay: float | None = None
            if not self.paused:
                if math.isinf(self.speed):
                    return
                if self._anchor is None:
                    self._anchor = (time.monotonic(), t_s)
                wall, t0 = self._anchor
                delay = wall + (t_s - t0) / self.speed - time.monotonic()
                if delay <= 0:
                    return
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._changed.wait(), delay)

    async def send(self, command: Command) -> None:
        await self.link.send(command)

    async def close(self) -> None:
        await self.link.close()
