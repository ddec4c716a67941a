"""The COMMAND_LONGs trimd waits on: each re-sent every :data:`RETRY_S` until the vehicle
answers it (COMMAND_ACK, not "in progress") or :data:`ANSWER_S` pass, at most one per
command id (a newer one supersedes it). Used by :class:`~trimd.drivers.mavlink.commands.Commander`
in the link's I/O thread."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.errors import LinkError
from trimd.drivers.mavlink.message import MavEncoder, MavMessage

__all__ = ["ACCEPTED", "ANSWER_S", "RETRY_S", "CommandRequests", "fail", "result_name",
           "succeed"]

RETRY_S = 1.0              # re-send an unanswered COMMAND_LONG after this long
ANSWER_S = 3.0             # give up on a command after this long
ACCEPTED, _IN_PROGRESS = 0, 5


def result_name(result: int | None) -> str:
    """MAV_RESULT's name of ``result`` (None: no answer)."""
    if result is None:
        return "no answer in 3 s"
    entry = mavlink2.enums["MAV_RESULT"].get(result)
    return entry.name if entry is not None else f"result {result}"


def fail(done: Future[None] | None, text: str) -> None:
    """Fail ``done`` (if any, and not done yet) with a LinkError saying ``text``."""
    if done is not None and not done.done():
        done.set_exception(LinkError(text))


def succeed(done: Future[None] | None) -> None:
    """Complete ``done`` (if any, and not done yet)."""
    if done is not None and not done.done():
        done.set_result(None)


@dataclass
class _Request:
    """An outstanding COMMAND_LONG, re-sent each second until answered or 3 s old."""

    params: tuple[float, ...]
    answered: Callable[[int | None], None]
    deadline: float
    done: Future[None] | None  # failed at once when the link is lost
    next_send: float = -math.inf
    tries: int = 0


class CommandRequests:
    """The outstanding COMMAND_LONGs of one pymavlink ``MAVLink`` object (``mav``), by
    command id; answers addressed to system ``own_sysid`` (or to none) count."""

    def __init__(self, mav: MavEncoder, own_sysid: int) -> None:
        self.mav = mav
        self.own_sysid = own_sysid
        self._pending: dict[int, _Request] = {}

    def __contains__(self, command: int) -> bool:
        return command in self._pending

    def send(self, command: int, params: tuple[float, ...], now: float,
             answered: Callable[[int | None], None], done: Future[None] | None) -> None:
        """Send ``command`` with ``params`` (up to 7) at the next :meth:`tick` and until
        answered; ``answered`` gets the MAV_RESULT (None: no answer in time)."""
        old = self._pending.pop(command, None)
        if old is not None:
            fail(old.done, "superseded by a newer command")
        self._pending[command] = _Request((*params, 0, 0, 0, 0, 0, 0, 0)[:7], answered,
                                          now + ANSWER_S, done)

    def ack(self, msg: MavMessage) -> None:
        """A COMMAND_ACK from the vehicle: the answer of the command it names."""
        request = self._pending.get(int(msg.command))
        target = int(getattr(msg, "target_system", 0) or 0)  # MAVLink 2 extension
        if (request is not None and int(msg.result) != _IN_PROGRESS
                and target in (0, self.own_sysid)):
            del self._pending[int(msg.command)]
            request.answered(int(msg.result))

    def forget(self, command: int) -> None:
        """Stop waiting on ``command`` without an answer (the vehicle showed it done)."""
        self._pending.pop(command, None)

    def fail_all(self, text: str) -> None:
        """Fail every waiting command's future with ``text`` and forget them all."""
        for request in self._pending.values():
            fail(request.done, text)
        self._pending.clear()

    def tick(self, now: float, sysid: int, compid: int) -> None:
        """Answer None to each command past its deadline; (re-)send each that is due."""
        for command, request in list(self._pending.items()):
            if now >= request.deadline:
                del self._pending[command]
                request.answered(None)
            elif now >= request.next_send:
                self.mav.command_long_send(sysid, compid, command, request.tries,
                                           *request.params)
                request.tries += 1
                request.next_send = now + RETRY_S

    def due(self) -> Iterator[float]:
        """The times something is due: each next send and each deadline."""
        for r in self._pending.values():
            yield r.next_send
            yield r.deadline
