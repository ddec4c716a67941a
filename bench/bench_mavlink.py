"""MAVLink ingest: typed samples/s from a 200 000-message .tlog beside bare pymavlink.

The file is the real traffic of ``mcqueen-small.tlog`` (its good records, every kind of
message a QGroundControl log holds), repeated and re-timestamped to 200 000 messages in a
temporary directory. trimd's path (:class:`trimd.logs.tlog.TlogReader` + the MAVLink decoder
into typed samples) is timed against ``mavutil.mavlink_connection(path).recv_msg()`` until
the end of the same file, which only parses. Both read every message; the ratio is
pymavlink's time over trimd's (≥ 1: trimd is faster; the issue asks ≥ 0.7).
"""

from __future__ import annotations

import struct
import tempfile
from pathlib import Path

from pymavlink import mavutil

from bench.size import size
from bench.timing import best_time
from trimd.core.profile_yaml import load_profile
from trimd.drivers.mavlink.decode import MavlinkDecoder
from trimd.logs.tlog import TlogReader

MESSAGES = size(200_000, 2_000)
SOURCE = Path(__file__).resolve().parents[1] / "tests" / "data" / "ardusub" / "mcqueen-small.tlog"


def write_tlog(path: Path, n: int = MESSAGES) -> None:
    """``n`` good records of the real log, repeated with continuing timestamps."""
    records = [(stamp, bytes(msg.get_msgbuf()))
               for stamp, msg in TlogReader.open(SOURCE).messages()]
    span = records[-1][0] - records[0][0] + 50_000
    with open(path, "wb") as f:
        for i in range(n):
            stamp, packet = records[i % len(records)]
            f.write(struct.pack(">Q", stamp + (i // len(records)) * span) + packet)


def main() -> None:
    profile = load_profile("bluerov2-heavy")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.tlog"
        write_tlog(path)
        counts = {"samples": 0, "messages": 0}

        def trimd() -> None:
            reader = TlogReader.open(path)
            counts["samples"] = sum(1 for _ in reader.samples(
                MavlinkDecoder.for_profile(profile)))
            counts["messages"] = reader.stats.messages

        def bare() -> None:
            conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
            n = 0
            while conn.recv_msg() is not None:
                n += 1
            counts["bare"] = n

        t_trimd, t_bare = best_time(trimd, repeat=3), best_time(bare, repeat=3)
    print(f"trimd tlog reader: {counts['messages']} messages → {counts['samples']} typed "
          f"samples in {t_trimd:.2f} s = {counts['samples'] / t_trimd:,.0f} samples/s "
          f"({counts['messages'] / t_trimd:,.0f} msg/s)")
    print(f"pymavlink mavlink_connection + recv_msg: {counts['bare']} messages in "
          f"{t_bare:.2f} s = {counts['bare'] / t_bare:,.0f} msg/s")
    print(f"ratio (same file, pymavlink time / trimd time): {t_bare / t_trimd:.2f} "
          f"(must be ≥ 0.7)")


if __name__ == "__main__":
    main()
