"""A recorded log as a :class:`trimd.core.link.Link` (``replay:<path>``), and what a log carries.

The samples come out in file order with the log's own times, as fast as the consumer
takes them (``speed=None``) or paced at ``speed`` × real time. Commands are accepted and
kept in :attr:`ReplayLink.sent` (a recording cannot obey them): replaying a trimd session
through the same procedure reproduces its live result, because the procedure is a pure
function of the samples.
"""

from __future__ import annotations

import asyncio
import json
import time
import zlib
from collections.abc import AsyncIterator, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from trimd.core.calibration_json import posterior_from_dict
from trimd.core.errors import DataError
from trimd.core.profile import Profile
from trimd.core.samples import Command, Sample
from trimd.drivers.mavlink.message import MavMessage
from trimd.logs.log import is_dataflash, open_log
from trimd.logs.recorder import (
    CALIBRATION_BLOCK,
    CALIBRATION_HOLD_BLOCK,
    FLOAT_BLOCK,
    PROFILE_BLOCK,
    SESSION_START,
    TRIMD_COMPONENT,
    TRIMD_SYSTEM,
    VERIFY_BLOCK,
)
from trimd.logs.tlog import TlogReader

__all__ = ["ReplayLink", "recorded_calibration_hold", "recorded_float_check", "recorded_notices",
           "recorded_profile_yaml", "recorded_trimd_texts", "recorded_verify_target",
           "with_recorded_thrust_map"]


_BLOCKS = (PROFILE_BLOCK, VERIFY_BLOCK, CALIBRATION_BLOCK, CALIBRATION_HOLD_BLOCK, FLOAT_BLOCK)


def _recorded_blocks(path: str | Path) -> dict[str, list[bytes]]:
    """The ENCAPSULATED_DATA blocks at the start of a trimd recording, by the start of the
    STATUSTEXT naming each (:data:`PROFILE_BLOCK`, :data:`VERIFY_BLOCK`,
    :data:`CALIBRATION_BLOCK`, :data:`CALIBRATION_HOLD_BLOCK`, :data:`FLOAT_BLOCK`); empty
    for other logs. Any other trimd message after a block ends them."""
    blocks: dict[str, list[bytes]] = {}
    current: str | None = None
    trimd = False
    for _, msg in TlogReader.open(path).messages():
        if (msg.get_srcSystem(), msg.get_srcComponent()) != (TRIMD_SYSTEM, TRIMD_COMPONENT):
            continue
        kind = msg.get_type()
        if kind == "STATUSTEXT" and msg.text == SESSION_START:
            trimd = True
        elif kind == "STATUSTEXT" and trimd and getattr(msg, "chunk_seq", 0) == 0 and any(
                msg.text.startswith(name) for name in _BLOCKS):
            current = next(n for n in _BLOCKS if msg.text.startswith(n))
            blocks[current] = []
        elif kind == "ENCAPSULATED_DATA" and current is not None:
            blocks[current].append(bytes(msg.data))
        elif kind == "STATUSTEXT" and getattr(msg, "chunk_seq", 0) > 0:
            continue  # the rest of a long header
        elif blocks:
            break
    return {k: v for k, v in blocks.items() if v}


def _gunzip(chunks: list[bytes], path: str | Path, what: str) -> str:
    gunzip = zlib.decompressobj(wbits=31)  # gzip; the zero padding of the last chunk stays
    try:
        text = gunzip.decompress(b"".join(chunks)).decode("utf-8")
    except (zlib.error, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: the recorded {what} is damaged ({exc})") from None
    if not gunzip.eof:
        raise DataError(f"{path}: the recorded {what} is cut short")
    return text


def recorded_profile_yaml(path: str | Path) -> str | None:
    """The vehicle profile a trimd recording carries (YAML text); None for other logs."""
    if is_dataflash(path):
        return None
    chunks = _recorded_blocks(path).get(PROFILE_BLOCK)
    return None if chunks is None else _gunzip(chunks, path, "profile")


def _recorded_json(path: str | Path, block: str, what: str) -> dict[str, Any] | None:
    """The JSON object of a recording's ``block`` (``what`` it is, for people); None when
    the recording has no such block, and for other logs."""
    if is_dataflash(path):
        return None
    chunks = _recorded_blocks(path).get(block)
    if chunks is None:
        return None
    try:
        value = json.loads(_gunzip(chunks, path, what))
    except json.JSONDecodeError as exc:
        raise DataError(f"{path}: the recorded {what} is damaged ({exc})") from None
    if not isinstance(value, dict):
        raise DataError(f"{path}: the recorded {what} is not a JSON object")
    return value


def recorded_verify_target(path: str | Path) -> dict[str, Any] | None:
    """The verify target a verify hold's recording carries (:mod:`trimd.app.verify`); None
    for a trim's recording (and for a verify hold recorded before trimd wrote it) and
    other logs."""
    return _recorded_json(path, VERIFY_BLOCK, "verify target")


def recorded_calibration_hold(path: str | Path) -> dict[str, Any] | None:
    """Which level hold of a deliberate calibration a recording is and the weight hung
    (:mod:`trimd.app.calibrate`); None for any other recording and other logs."""
    return _recorded_json(path, CALIBRATION_HOLD_BLOCK, "calibration hold")


def recorded_float_check(path: str | Path) -> dict[str, Any] | None:
    """The settings a float check's recording carries (:mod:`trimd.app.float_check`);
    None for any other recording and other logs."""
    return _recorded_json(path, FLOAT_BLOCK, "float check")


def with_recorded_thrust_map(path: str | Path, profile: Profile) -> Profile:
    """``profile`` with the thrust map's calibration the recording carries (the live
    session's, :mod:`trimd.core.calibration`); ``profile`` itself when it carries none."""
    d = _recorded_json(path, CALIBRATION_BLOCK, "thrust map calibration")
    if d is None:
        return profile
    return replace(profile, thrust_map=posterior_from_dict(
        d, f"{path} (recorded thrust map calibration)"))


def recorded_trimd_texts(path: str | Path) -> Iterator[str]:
    """The texts trimd wrote into a recording (notices, state changes), in file order;
    each text's first chunk only."""
    if is_dataflash(path):
        return
    for _, msg in TlogReader.open(path).messages():
        if ((msg.get_srcSystem(), msg.get_srcComponent()) == (TRIMD_SYSTEM, TRIMD_COMPONENT)
                and msg.get_type() == "STATUSTEXT" and getattr(msg, "chunk_seq", 0) == 0):
            yield str(msg.text)


def recorded_notices(path: str | Path) -> Iterator[str]:
    """The whole texts trimd wrote into a recording, in file order: each text's chunks
    joined as bytes and then decoded (a character may straddle two chunks)."""
    if is_dataflash(path):
        return
    parts: list[bytes] = []
    for _, msg in TlogReader.open(path).messages():
        if ((msg.get_srcSystem(), msg.get_srcComponent()) != (TRIMD_SYSTEM, TRIMD_COMPONENT)
                or msg.get_type() != "STATUSTEXT"):
            continue
        if getattr(msg, "chunk_seq", 0) == 0 and parts:
            yield b"".join(parts).decode("utf-8", "replace")
            parts = []
        parts.append(_statustext_bytes(msg))
    if parts:
        yield b"".join(parts).decode("utf-8", "replace")


def _statustext_bytes(msg: MavMessage) -> bytes:
    """The text bytes of a MAVLink 2 STATUSTEXT as sent (pymavlink decodes each chunk on
    its own): after the 10-byte header and the severity byte, up to 50 bytes, the
    packet's zero-truncated tail restored."""
    buf = bytes(msg.get_msgbuf())
    if buf[:1] != b"\xfd":   # MAVLink 1: no chunks, the decoded text is whole
        return str(msg.text).encode("utf-8")
    payload = buf[10:10 + buf[1]].ljust(54, b"\0")
    return payload[1:51].rstrip(b"\0")


class ReplayLink:
    """Samples of a ``.tlog`` (any MAVLink log) or an ArduSub DataFlash ``.bin``."""

    def __init__(self, path: str | Path, profile: Profile, *, speed: float | None = None
                 ) -> None:
        self.path = str(path)
        self.description = f"replay:{path}"
        self.profile = profile
        self.speed = speed
        self.sent: list[Command] = []
        self._log = open_log(path, profile)
        self._closed = False

    def read_samples(self) -> Iterator[Sample]:
        """Every sample of the log, in file order (:attr:`warnings` grow on the way)."""
        yield from self._log.samples()

    @property
    def warnings(self) -> list[str]:
        """The damage found in what has been read so far (a session may stop early)."""
        return self._log.warnings()

    async def samples(self) -> AsyncIterator[Sample]:
        start_wall: float | None = None
        start_t = 0.0
        for sample in self.read_samples():
            if self._closed:
                return
            if self.speed:
                if start_wall is None:
                    start_wall, start_t = time.monotonic(), sample.t_s
                delay = (sample.t_s - start_t) / self.speed - (time.monotonic() - start_wall)
                if delay > 0:
                    await asyncio.sleep(delay)
            else:
                await asyncio.sleep(0)
            yield sample

    async def send(self, command: Command) -> None:
        self.sent.append(command)

    async def close(self) -> None:
        self._closed = True
