"""A fast, robust reader of MAVLink telemetry logs (``.tlog``).

A ``.tlog`` is a sequence of records: an 8-byte big-endian timestamp [µs since the Unix
epoch; the low 2 bits may carry a link id] followed by one raw MAVLink packet. QGroundControl,
MAVProxy and trimd's recorder write it.

The packets are decoded by calling ``MAVLink.decode`` of pymavlink's generated
``dialects.v20.ardupilotmega`` module directly, one record at a time, rather than through
``mavutil.mavlink_connection(...).recv_msg()`` (docs/ardusub.md measures about 2.65× more
messages/s this way). The dialect and the protocol are pinned by that import: the v20
module's decoder takes MAVLink 2 packets (magic 0xFD) and MAVLink 1 packets (0xFE) alike,
and nothing here reads or sets the ``MAVLINK20`` environment variable, so no other module's
pymavlink state changes. (pymavlink does read ``MAV_IGNORE_CRC`` when the dialect is first
imported; with it set, bad-CRC frames would decode as good ones.)

Damage never raises:

* a frame whose CRC (or length, or payload) does not check, followed by a plausible next
  record, is one *bad CRC* frame and reading continues right after it;
* anything else (a bad magic byte, a timestamp more than a day away from the previous
  good one, a bad frame that is not followed by a record) starts a *resync*: the reader
  scans forward byte by byte to the next record that decodes; the skipped stretch is one
  bad frame and its bytes are counted;
* a well-framed packet of a message id the dialect does not know cannot be checked (its
  CRC depends on the message definition): it is counted in ``unknown`` and skipped, and it
  never ends a resync;
* a final record cut short by the end of the file is reported (``truncated_at``, the byte
  offset where it starts), not decoded.

Every byte of the file is accounted for: good records + bad-CRC and unknown frames +
skipped bytes + the truncated tail = the file size (:meth:`TlogStats.accounted_bytes`).
"""

from __future__ import annotations

import mmap
import re
import struct
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from trimd.core.errors import DataError
from trimd.core.samples import Confirmed, Sample
from trimd.drivers.mavlink.decode import MavlinkDecoder
from trimd.drivers.mavlink.message import MavMessage
from trimd.logs.recorder import SESSION_START, TRIMD_COMPONENT, TRIMD_SYSTEM, session_s

__all__ = ["MAX_TIME_JUMP_US", "TlogReader", "TlogStats"]

#: The bytes of a log: read into memory or mapped.
Buffer = bytes | bytearray | memoryview | mmap.mmap

#: A record's timestamp more than this away from the previous good one is corrupt.
MAX_TIME_JUMP_US = 24 * 3600 * 1_000_000
_V1, _V2 = 0xFE, 0xFD
_MAGIC = re.compile(rb"[\xfd\xfe]")
_STAMP = struct.Struct(">Q")
#: What trimd's recorder writes for a command (:meth:`TlogRecorder.command`; a release
#: is a text, and comes only after one of these).
_COMMANDS = frozenset({"SET_ATTITUDE_TARGET", "MANUAL_CONTROL", "COMMAND_LONG"})


@dataclass
class TlogStats:
    """What reading a ``.tlog`` found (filled in as the messages are read).

    ``messages`` counts the good (CRC-checked) ones, ``counts`` them by type; ``gaps``
    counts messages missing from each sender's sequence numbers, keyed by (system id,
    component id); frames lost to CRC errors show up there too. ``first_bad_at`` is the
    byte offset of the first bad frame (a CRC error or the start of a damaged stretch),
    None when there is none.
    """

    size_bytes: int = 0
    messages: int = 0
    good_bytes: int = 0
    bad_crc: int = 0
    bad_crc_bytes: int = 0
    resyncs: int = 0
    skipped_bytes: int = 0
    truncated_at: int | None = None
    first_bad_at: int | None = None
    unknown: int = 0
    unknown_bytes: int = 0
    gaps: Counter[tuple[int, int]] = field(default_factory=Counter)
    counts: Counter[str] = field(default_factory=Counter)
    first_us: int | None = None
    last_us: int | None = None

    @property
    def bad_frames(self) -> int:
        """Bad-CRC frames plus damaged stretches skipped by a resync."""
        return self.bad_crc + self.resyncs

    @property
    def accounted_bytes(self) -> int:
        """Bytes in good records, bad and unknown frames, skipped stretches, truncated tail."""
        tail = 0 if self.truncated_at is None else self.size_bytes - self.truncated_at
        return (self.good_bytes + self.bad_crc_bytes + self.unknown_bytes
                + self.skipped_bytes + tail)


def _packet_len(buf: Buffer, i: int, n: int) -> int:
    """Length of the packet whose magic byte is at ``i``; −1: no magic; 0: header cut."""
    magic = buf[i]
    if magic == _V2:
        return 12 + buf[i + 1] + (13 if buf[i + 2] & 1 else 0) if i + 3 <= n else 0
    if magic == _V1:
        return 8 + buf[i + 1] if i + 2 <= n else 0
    return -1


class TlogReader:
    """Read one ``.tlog`` held in memory (:meth:`open` maps a file).

    Iterate :meth:`messages` for ``(timestamp_us, message)`` pairs or :meth:`samples` for
    typed samples; either fills :attr:`stats`. Sample time ``t_s`` is measured from the
    first good record.
    """

    def __init__(self, data: Buffer, name: str = "<tlog>") -> None:
        self._buf = data
        self.name = name
        self.stats = TlogStats(size_bytes=len(data))
        self._mav = mavlink2.MAVLink(None)

    @classmethod
    def open(cls, path: str | Path) -> TlogReader:
        """Map ``path``; DataError when it cannot be read."""
        try:
            with open(path, "rb") as f:
                size = f.seek(0, 2)
                data: bytes | mmap.mmap = (mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
                                           if size else b"")
        except OSError as exc:
            raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
        return cls(data, str(path))

    def _decode(self, start: int, end: int) -> MavMessage | None:
        try:
            msg: MavMessage = self._mav.decode(bytearray(self._buf[start:end]))
            return msg
        except (mavlink2.MAVError, struct.error):
            return None

    def _plausible(self, pos: int, n: int, last_us: int | None) -> bool:
        """Whether a record can start at ``pos`` (magic byte, timestamp near the last)."""
        if pos + 9 > n or self._buf[pos + 8] not in (_V1, _V2):
            return False
        return last_us is None or abs(_STAMP.unpack_from(self._buf, pos)[0] - last_us) <= (
            MAX_TIME_JUMP_US)

    def messages(self) -> Iterator[tuple[int, MavMessage]]:
        """``(timestamp_us, pymavlink message)`` for every good record, in file order."""
        buf, n, st = self._buf, len(self._buf), self.stats
        pos, last_us = 0, None
        lost_from, cut = -1, False  # lost_from ≥ 0: resyncing since there
        seqs: dict[tuple[int, int], int] = {}
        while pos + 9 <= n:
            stamp = _STAMP.unpack_from(buf, pos)[0]
            plen = _packet_len(buf, pos + 8, n) if self._plausible(pos, n, last_us) else -1
            end = pos + 8 + plen
            msg = self._decode(pos + 8, end) if plen > 0 and end <= n else None
            if msg is not None and not isinstance(msg, mavlink2.MAVLink_unknown):
                if lost_from >= 0:
                    self._bad_at(lost_from)
                    st.resyncs += 1
                    st.skipped_bytes += pos - lost_from
                    lost_from = -1
                self._count(msg, buf, pos + 8, seqs)
                st.good_bytes += end - pos
                st.first_us = stamp if st.first_us is None else st.first_us
                st.last_us = last_us = stamp
                yield stamp, msg
                pos = end
            elif lost_from < 0 and plen > 0 and end <= n and (
                    end + 9 > n or self._plausible(end, n, last_us)):
                if msg is None:
                    self._bad_at(pos)
                    st.bad_crc += 1
                    st.bad_crc_bytes += end - pos
                else:
                    st.unknown += 1
                    st.unknown_bytes += end - pos
                pos = end
            else:
                if lost_from < 0:  # a record running past the end may be the last one
                    lost_from, cut = pos, plen > 0 and end > n
                found = _MAGIC.search(buf, pos + 9)
                pos = n if found is None else found.start() - 8
        if lost_from >= 0 and cut:
            st.truncated_at = lost_from
        elif lost_from >= 0:
            self._bad_at(lost_from)
            st.resyncs += 1
            st.skipped_bytes += n - lost_from
        elif pos < n:
            st.truncated_at = pos

    def _bad_at(self, pos: int) -> None:
        if self.stats.first_bad_at is None:
            self.stats.first_bad_at = pos

    def _count(self, msg: MavMessage, buf: Buffer, i: int, seqs: dict[tuple[int, int], int]
               ) -> None:
        st = self.stats
        st.messages += 1
        st.counts[msg.get_type()] += 1
        seq, key = (buf[i + 4], (buf[i + 5], buf[i + 6])) if buf[i] == _V2 else (
            buf[i + 2], (buf[i + 3], buf[i + 4]))
        last = seqs.get(key)
        if last is not None:
            st.gaps[key] += (seq - last - 1) & 0xFF
        seqs[key] = seq

    def samples(self, decoder: MavlinkDecoder) -> Iterator[Sample]:
        """Typed samples of every good record through ``decoder``; t_s from the first record.

        In a trimd recording (it starts with trimd's session-start text), trimd's first
        command is preceded by :class:`Confirmed` at its place in the file."""
        st = self.stats
        recording, commanded = False, False
        for stamp, msg in self.messages():
            decoder.bad_frames = st.bad_frames
            assert st.first_us is not None
            t_s = session_s(stamp - st.first_us)
            if (msg.get_srcSystem(), msg.get_srcComponent()) == (TRIMD_SYSTEM,
                                                                 TRIMD_COMPONENT):
                kind = msg.get_type()
                recording |= kind == "STATUSTEXT" and msg.text == SESSION_START
                if recording and not commanded and kind in _COMMANDS:
                    commanded = True
                    yield Confirmed(t_s)
            yield from decoder.decode(msg, t_s)
