"""ArduSub DataFlash (``.BIN``) logs into typed samples, through pymavlink's DFReader.

==========  ===================================================================
record      sample
==========  ===================================================================
ATT         :class:`Attitude`: Roll, Pitch, Yaw [deg] → rad (yaw wrapped to ±π), body
            rates from the latest RATE record (R, P, Y [deg/s] → rad/s; an ATT
            before any RATE is rejected: its rates are unknown)
RCOU        :class:`Thrusters`: C1…C14 [µs] of the profile's channels
CTUN        :class:`Depth` = −Alt [m] (the depth controller's estimate)
BARO        :class:`Depth` = −Alt [m] of one instance (``depth_source="baro"``)
BAT         :class:`Battery`: Volt [V] of instance 0
MODE        :class:`Health`: ModeNum (ArduSub mode)
ARM, EV     :class:`Health`: ArmState; events 10 ARMED / 11 DISARMED
PARM        :class:`~trimd.drivers.mavlink.decode.VehicleParams` (FRAME_CONFIG, SERVOn_FUNCTION,
            MOT_n_DIRECTION), SERVOn_FUNCTION remaps RCOU outputs as for MAVLink
MSG         :class:`VehicleText` (severity 6, info: the record has none); the first
            "ArduSub V…" is the firmware string
==========  ===================================================================

The field names come from the log's own FMT records; UNIT/MULT/FMTU metadata is never
used (an excerpt such as gat-00000029_filtered.BIN has none). Sample time ``t_s`` is
TimeUS [s since boot] minus that of the first timestamped record. Range checks are those
of :mod:`trimd.drivers.mavlink.decode`; a rejected record is counted in ``rejected``.
A log without ARM/EV records leaves the armed state unknown: Health then says
``armed=None`` (with ``detail="armed state not logged"`` for people) and ``armed_known``
is False. Mode numbers are ArduSub's: Health carries their
:class:`~trimd.core.samples.ModeClass` (:func:`trimd.drivers.mavlink.ardusub.mode_class`).

Damage: DFReader skips bytes it cannot parse and prints about them on stderr; here its
output is kept off the terminal and the damage is counted instead: ``skipped_bytes``
and ``first_skip_at`` for garbage between records, ``truncated_at`` for an incomplete
record at the end (a log cut off mid-write).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import sys
from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Literal

from pymavlink import DFReader

from trimd.core.errors import DataError
from trimd.core.samples import Health, ModeClass, Sample, VehicleText
from trimd.drivers.mavlink.ardusub import mode_class, mode_name
from trimd.drivers.mavlink.decode import (
    VehicleParams,
    checked_attitude,
    checked_battery,
    checked_depth,
    checked_thrusters,
)
from trimd.drivers.mavlink.message import MavLogReader, MavMessage

__all__ = ["DataflashReader"]

_EV_ARMED, _EV_DISARMED = 10, 11
_MSG_SEVERITY = 6  # MAV_SEVERITY_INFO: a MSG record carries no severity


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence standard error, at the file-descriptor level too: pymavlink's compiled
    DataFlash indexer prints a line per damaged byte from C, past ``sys.stderr``."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        with contextlib.redirect_stderr(io.StringIO()):
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


class DataflashReader:
    """Read one DataFlash log.

    Parameters
    ----------
    path : the ``.BIN`` file.
    channels : the profile's thruster channels (ArduSub motor numbers); None: the motors
        the log's SERVOn_FUNCTION parameters name (1..8 when it has none).
    depth_source : ``"ctun"`` (CTUN.Alt) or ``"baro"`` (BARO.Alt of ``baro_instance``;
        ArduSub's external Bar30 is usually instance 1).
    """

    def __init__(self, path: str | Path, channels: Sequence[int] | None = None, *,
                 depth_source: Literal["ctun", "baro"] = "ctun", baro_instance: int = 1
                 ) -> None:
        self.path = str(path)
        self.channels = None if channels is None else tuple(channels)
        self.depth_source = depth_source
        self.baro_instance = baro_instance
        self.params = VehicleParams()
        self.firmware: str | None = None
        self.counts: Counter[str] = Counter()
        self.rejected: Counter[str] = Counter()
        self.first_us: int | None = None
        self.last_us: int | None = None
        self.mode: str | None = None
        self.mode_class = ModeClass.UNKNOWN
        self.armed = False
        self.armed_known = False
        self.error: str | None = None  # why reading stopped early, if it did
        self.skipped_bytes = 0
        self.first_skip_at: int | None = None
        self.truncated_at: int | None = None
        self._rates: tuple[float, float, float] | None = None
        try:
            with _quiet_stderr():  # its indexer's "bad header" lines, one per byte
                self._log: MavLogReader = DFReader.DFReader_binary(self.path, zero_time_base=False)
        except OSError as exc:
            raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
        except Exception as exc:  # DFReader raises anything on a file that is not a log
            raise DataError(f"{path}: not a DataFlash log ({exc})") from None

    def records(self) -> Iterator[MavMessage]:
        """Every DFReader record in file order; counts them, notes the time span and the
        damage (module docstring)."""
        while True:
            offset = self._log.offset
            try:
                with contextlib.redirect_stderr(io.StringIO()):  # "Skipped N bad bytes"
                    msg = self._log.recv_msg()
            except Exception as exc:  # a damaged record: stop there, say where
                self.error = f"unreadable record at byte {offset}: {exc}"
                return
            if msg is None:
                if self._log.data_len > offset:  # bytes left that make no record
                    self.truncated_at = offset
                return
            skipped = self._log.offset - msg.fmt.len - offset
            if skipped > 0:
                self.skipped_bytes += skipped
                self.first_skip_at = offset if self.first_skip_at is None else self.first_skip_at
            self.counts[msg.get_type()] += 1
            stamp = getattr(msg, "TimeUS", None)
            if isinstance(stamp, int):
                self.first_us = stamp if self.first_us is None else self.first_us
                self.last_us = stamp
            yield msg

    def samples(self) -> Iterator[Sample]:
        """Typed samples of every record that carries one."""
        for msg in self.records():
            if self.first_us is None or not hasattr(msg, "TimeUS"):
                continue
            kind = msg.get_type()
            t_s = (msg.TimeUS - self.first_us) * 1e-6
            sample = self._convert(kind, msg, t_s)
            if sample is None:
                self.rejected[kind] += 1
            elif not isinstance(sample, bool):
                yield sample

    def _convert(self, kind: str, msg: MavMessage, t_s: float) -> Sample | bool | None:
        """A sample, None for a rejected record, or True when the record carries none."""
        if kind == "ATT":
            if self._rates is None:
                return None
            yaw = math.remainder(math.radians(msg.Yaw), 2 * math.pi)
            return checked_attitude(t_s, math.radians(msg.Roll), math.radians(msg.Pitch),
                                    yaw, *self._rates)
        if kind == "RATE":
            self._rates = (math.radians(msg.R), math.radians(msg.P), math.radians(msg.Y))
            return True
        if kind == "RCOU":
            return checked_thrusters(t_s, (getattr(msg, f"C{self.params.output_of(c)}", 0)
                                           for c in self.channels or self.params.motors()))
        if (kind == "CTUN" and self.depth_source == "ctun") or (
                kind == "BARO" and self.depth_source == "baro"
                and getattr(msg, "I", 0) == self.baro_instance):
            return checked_depth(t_s, -float(msg.Alt))
        if kind == "BAT" and getattr(msg, "Instance", getattr(msg, "Inst", 0)) == 0:
            return checked_battery(t_s, float(msg.Volt))
        if kind == "PARM":
            self.params.update(str(msg.Name), float(msg.Value))
        elif kind == "MSG":
            text = str(msg.Message)
            if self.firmware is None and text.startswith("ArduSub"):
                self.firmware = text
            return VehicleText(t_s, _MSG_SEVERITY, text)
        elif kind == "MODE":
            number = int(getattr(msg, "ModeNum", msg.Mode))
            self.mode, self.mode_class = mode_name(number), mode_class(number)
            return self._health(t_s)
        elif kind == "ARM" or (kind == "EV" and msg.Id in (_EV_ARMED, _EV_DISARMED)):
            self.armed = bool(msg.ArmState) if kind == "ARM" else msg.Id == _EV_ARMED
            self.armed_known = True
            return self._health(t_s)
        return True

    def _health(self, t_s: float) -> Health | bool:
        if self.mode is None:  # armed before any MODE record: wait for the mode
            return True
        if self.armed_known:
            return Health(t_s, True, self.mode, self.armed, mode_class=self.mode_class)
        return Health(t_s, True, self.mode, None, detail="armed state not logged",
                      mode_class=self.mode_class)
