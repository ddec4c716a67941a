"""What trimd says about itself on the MAVLink network: its heartbeat, texts and values.

:class:`Outbox` runs in the link's I/O thread beside the
:class:`~trimd.drivers.mavlink.commands.Commander` and writes through the same pymavlink
``MAVLink`` object; :meth:`Outbox.put` may be called from any thread. It sends

* HEARTBEAT every :data:`HEARTBEAT_PERIOD_S`, always: type GCS (6) with trimd's own ids,
  ONBOARD_CONTROLLER (18) as a component of the vehicle (``ids=vehicle``), autopilot
  INVALID (8);
* :class:`~trimd.core.announce.Text` as STATUSTEXT at its severity, spelled in ASCII
  (:func:`~trimd.drivers.mavlink.statustext.ascii_text`), in chunks with an ``id`` when
  longer than 50 bytes. The budget (``docs/mavlink.md``): ALERT and more urgent go at
  once; any other text at most one per :data:`TEXT_PERIOD_S` (all its chunks); of the
  texts waiting, a newer INFO replaces older INFOs (a phase that passed while waiting
  is not news), and at most :data:`MAX_WAITING` wait (the oldest is dropped, counted);
* :class:`~trimd.core.announce.Values` as NAMED_VALUE_FLOAT, each name at most once per
  :data:`VALUE_PERIOD_S` (a newer value waiting replaces the older), ``time_boot_ms`` the
  milliseconds since the link opened.

With ``enabled=False`` (the URL's ``announce=off``) only the heartbeat goes out.
"""

from __future__ import annotations

import math
import queue
from collections import deque

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.announce import Announcement, Severity, Text, Values
from trimd.drivers.mavlink.message import MavEncoder
from trimd.drivers.mavlink.statustext import ascii_text, text_chunks

__all__ = ["HEARTBEAT_PERIOD_S", "MAX_WAITING", "TEXT_PERIOD_S", "VALUE_PERIOD_S", "Outbox"]

HEARTBEAT_PERIOD_S = 1.0
#: Non-urgent STATUSTEXT: at most one text (all its chunks) per this long [s].
TEXT_PERIOD_S = 5.0
#: NAMED_VALUE_FLOAT: each name at most once per this long [s].
VALUE_PERIOD_S = 1.0
#: Non-urgent texts that may wait for the budget; beyond, the oldest is dropped.
MAX_WAITING = 8


class Outbox:
    """trimd's heartbeat, texts and values over ``mav`` (module docstring).

    Parameters
    ----------
    mav : the pymavlink ``MAVLink`` object of the link (written only by the I/O thread).
    mav_type : the heartbeat's MAV_TYPE (6 GCS, 18 ONBOARD_CONTROLLER).
    t0 : the link's start on the ``now`` clock of :meth:`tick` [s].
    enabled : False: texts and values are dropped, only the heartbeat goes out.
    """

    def __init__(self, mav: MavEncoder, *, mav_type: int, t0: float, enabled: bool = True) -> None:
        self.mav = mav
        self.mav_type = mav_type
        self.t0 = t0
        self.enabled = enabled
        #: texts sent, texts dropped (budget or ``enabled=False``), values sent
        self.sent_texts = self.dropped_texts = self.sent_values = 0
        self._inbox: queue.SimpleQueue[Announcement] = queue.SimpleQueue()
        self._waiting: deque[Text] = deque()
        self._values: dict[str, float] = {}            # name → latest value not yet sent
        self._value_due: dict[str, float] = {}         # name → earliest next send
        self._heartbeat_due = -math.inf
        self._text_due = -math.inf
        self._text_id = 0

    def put(self, item: Announcement) -> None:
        """Queue ``item`` (any thread); it goes out at the next :meth:`tick` it may."""
        if self.enabled:
            self._inbox.put(item)
        elif isinstance(item, Text):
            self.dropped_texts += 1

    def tick(self, now: float) -> float:
        """Send what is due at ``now`` [s]; return when something is due next."""
        if now >= self._heartbeat_due:
            self.mav.heartbeat_send(self.mav_type, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0,
                                    mavlink2.MAV_STATE_ACTIVE)
            self._heartbeat_due = now + HEARTBEAT_PERIOD_S
        self._take(now)
        if self._waiting and now >= self._text_due:
            self._send_text(self._waiting.popleft())
            self._text_due = now + TEXT_PERIOD_S
        for name in [n for n in self._values if now >= self._value_due.get(n, -math.inf)]:
            ms = max(0, round((now - self.t0) * 1000)) & 0xFFFFFFFF
            self.mav.named_value_float_send(ms, name.encode("ascii"), self._values.pop(name))
            self._value_due[name] = now + VALUE_PERIOD_S
            self.sent_values += 1
        waits = [self._heartbeat_due, *(self._value_due[n] for n in self._values)]
        if self._waiting:
            waits.append(self._text_due)
        return min(waits)

    def flush(self, now: float) -> None:
        """Send every text and value still waiting, whatever the budget (the link is
        closing: a trim's last words must not wait for a budget that ends with it)."""
        self._take(now)
        while self._waiting:
            self._send_text(self._waiting.popleft())
        self._value_due.clear()
        self.tick(now)

    def _take(self, now: float) -> None:
        """Move what was put into the budgets; urgent texts go out at once."""
        while True:
            try:
                item = self._inbox.get_nowait()
            except queue.Empty:
                return
            if isinstance(item, Values):
                self._values.update(item.values)
            elif item.urgent:
                self._send_text(item)
            else:
                if item.severity == Severity.INFO:
                    kept = deque(t for t in self._waiting if t.severity != Severity.INFO)
                    self.dropped_texts += len(self._waiting) - len(kept)
                    self._waiting = kept
                self._waiting.append(item)
                while len(self._waiting) > MAX_WAITING:
                    self._waiting.popleft()
                    self.dropped_texts += 1

    def _send_text(self, item: Text) -> None:
        chunks = text_chunks(ascii_text(item.text))
        text_id = 0
        if len(chunks) > 1:
            self._text_id = self._text_id % 0xFFFF + 1
            text_id = self._text_id
        for seq, chunk in enumerate(chunks):
            self.mav.statustext_send(int(item.severity), chunk, text_id, seq)
        self.sent_texts += 1
