"""Any vehicle log, read one way: a MAVLink ``.tlog`` or an ArduSub DataFlash ``.BIN``.

:func:`open_log` looks at the file's first bytes and returns a :class:`VehicleLog`: typed
samples in file order (times [s] from the log's first record), the damage found on the way
(:meth:`VehicleLog.warnings`), and what the log holds (:meth:`VehicleLog.summary`: format,
span, vehicle, message counts, parameters). The replay link, ``trimd inspect`` and
``trimd identify`` all read logs through it, so a DataFlash log works wherever a tlog does.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Protocol

from trimd.core.errors import DataError
from trimd.core.profile import Profile
from trimd.core.samples import PilotInput, Sample, VehicleText
from trimd.drivers.mavlink.decode import MavlinkDecoder
from trimd.logs.dataflash import DataflashReader
from trimd.logs.recorder import PILOT_TEXT
from trimd.logs.tlog import TlogReader

__all__ = ["DataflashLog", "TlogLog", "VehicleLog", "is_dataflash", "open_log"]

_DATAFLASH_HEAD = b"\xa3\x95"


class VehicleLog(Protocol):
    """One log file being read."""

    path: str

    def samples(self) -> Iterator[Sample]:
        """Every sample of the log, in file order; :meth:`warnings` grow on the way."""
        ...

    def warnings(self) -> list[str]:
        """The damage found in what has been read so far (a reader may stop early)."""
        ...

    def summary(self) -> dict[str, Any]:
        """What the log holds, JSON-ready except ``counts`` (a Counter of record types) and
        ``params`` (:class:`~trimd.drivers.mavlink.decode.VehicleParams`); complete once
        :meth:`samples` has been read to the end."""
        ...


def is_dataflash(path: str | Path) -> bool:
    """A DataFlash log starts with the 0xA3 0x95 record header; a tlog does not."""
    try:
        with open(path, "rb") as f:
            return f.read(2) == _DATAFLASH_HEAD
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None


def open_log(path: str | Path, profile: Profile | None = None) -> VehicleLog:
    """The log at ``path``; ``profile`` names the thruster channels (None: the log's own,
    or the defaults). A file that cannot be read is a DataError."""
    return DataflashLog(path, profile) if is_dataflash(path) else TlogLog(path, profile)


def _damage(path: str, truncated_at: int | None, skipped: int, what: str,
            first_skip_at: int | None) -> list[str]:
    """The warnings for a truncated tail and for ``skipped`` damaged pieces (``what``)."""
    out = []
    if truncated_at is not None:
        out.append(f"{path}: truncated record at byte {truncated_at}; read up to there")
    if skipped:
        out.append(f"{path}: {skipped} {what} skipped (the first at byte {first_skip_at})")
    return out


def _span_s(first_us: int | None, last_us: int | None) -> float:
    return 0.0 if first_us is None or last_us is None else (last_us - first_us) * 1e-6


class TlogLog:
    """A MAVLink ``.tlog`` (any ground station's) through trimd's decoder. The vehicle
    text trimd's recorder writes for someone else taking over (``PILOT_TEXT``) comes
    back as the :class:`PilotInput` it was, so a replay ends where the session did."""

    def __init__(self, path: str | Path, profile: Profile | None = None) -> None:
        self.path = str(path)
        try:
            self._reader = TlogReader.open(path)
        except OSError as exc:
            raise DataError(f"{path}: cannot read: {exc.strerror or exc}") from None
        self._decoder = MavlinkDecoder.for_profile(profile) if profile else MavlinkDecoder()
        self._firmware: str | None = None

    def samples(self) -> Iterator[Sample]:
        for sample in self._reader.samples(self._decoder):
            if (self._firmware is None and isinstance(sample, VehicleText)
                    and sample.text.startswith("ArduSub")):
                self._firmware = sample.text
            if isinstance(sample, VehicleText) and sample.text.startswith(PILOT_TEXT):
                yield PilotInput(sample.t_s, sample.text.removeprefix(PILOT_TEXT))
            else:
                yield sample

    def warnings(self) -> list[str]:
        st = self._reader.stats
        return _damage(self.path, st.truncated_at, st.bad_frames, "bad frames",
                       st.first_bad_at)

    def summary(self) -> dict[str, Any]:
        st, decoder = self._reader.stats, self._decoder
        if st.messages == 0:
            raise DataError(f"{self.path}: no MAVLink message could be read "
                            f"({st.size_bytes} bytes, {st.bad_frames} bad frames)")
        return {
            "format": "MAVLink tlog",
            "start": None if st.first_us is None else f"unix {st.first_us / 1e6:.3f} s",
            "duration_s": _span_s(st.first_us, st.last_us), "firmware": self._firmware,
            "vehicle": None if decoder.vehicle is None else
            f"system {decoder.vehicle[0]} component {decoder.vehicle[1]}",
            "counts": st.counts, "params": decoder.params,
            "armed_known": decoder.armed is not None,
            "messages": st.messages, "bad_frames": st.bad_frames, "bad_crc": st.bad_crc,
            "skipped_bytes": st.skipped_bytes, "truncated_at": st.truncated_at,
            "first_skip_at": st.first_bad_at,
            "sequence_gaps": {f"{s}/{c}": n for (s, c), n in sorted(st.gaps.items()) if n},
            "rejected": dict(decoder.rejected),
        }


class DataflashLog:
    """An ArduSub DataFlash ``.BIN`` (the autopilot's own log)."""

    def __init__(self, path: str | Path, profile: Profile | None = None) -> None:
        self.path = str(path)
        self._reader = DataflashReader(
            path, None if profile is None else [t.channel for t in profile.thrusters])

    def samples(self) -> Iterator[Sample]:
        return self._reader.samples()

    def warnings(self) -> list[str]:
        r = self._reader
        return ([f"{self.path}: {r.error}; read up to there"] if r.error else []) + _damage(
            self.path, r.truncated_at, r.skipped_bytes, "damaged bytes", r.first_skip_at)

    def summary(self) -> dict[str, Any]:
        r = self._reader
        if not r.counts:
            raise DataError(f"{self.path}: no DataFlash record could be read")
        counts: Counter[str] = r.counts
        return {
            "format": "ArduPilot DataFlash", "duration_s": _span_s(r.first_us, r.last_us),
            "start": None if r.first_us is None else f"boot + {r.first_us / 1e6:.3f} s",
            "firmware": r.firmware, "vehicle": None, "counts": counts,
            "params": r.params, "armed_known": r.armed_known,
            "messages": sum(counts.values()), "bad_frames": 0,
            "truncated_at": r.truncated_at, "skipped_bytes": r.skipped_bytes,
            "first_skip_at": r.first_skip_at, "error": r.error,
            "rejected": dict(r.rejected),
        }
