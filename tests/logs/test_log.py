"""One way to read any log: the replay link, ``trimd inspect`` and ``trimd identify`` all go
through :func:`trimd.logs.log.open_log`, so they see the same samples of the same file."""

from __future__ import annotations

import asyncio
from collections import Counter
from pathlib import Path

import pytest

from tests.helpers import ARDUSUB_LOGS
from trimd.app.log_report import inspect_log
from trimd.core.errors import DataError
from trimd.core.profile import Profile
from trimd.logs.log import DataflashLog, TlogLog, open_log
from trimd.logs.replay import ReplayLink

LOGS = ["mcqueen-small.tlog", "mcqueen-small.BIN", "mcqueen-bad-crc.tlog"]


@pytest.mark.parametrize("name", LOGS)
def test_replay_and_inspect_see_the_same_samples(name: str, bluerov: Profile) -> None:
    path = ARDUSUB_LOGS / name
    log = open_log(path, bluerov)
    assert isinstance(log, DataflashLog if name.endswith(".BIN") else TlogLog)
    kinds = Counter(type(s).__name__ for s in log.samples())
    assert kinds["Attitude"] > 100

    async def replayed() -> Counter[str]:
        link = ReplayLink(path, bluerov)
        return Counter([type(s).__name__ async for s in link.samples()])

    assert asyncio.run(replayed()) == kinds
    assert inspect_log(path, bluerov)["samples"] == dict(kinds)


def test_damage_is_a_warning_and_counts_are_by_type(bluerov: Profile) -> None:
    log = open_log(ARDUSUB_LOGS / "mcqueen-bad-crc.tlog", bluerov)
    n = sum(1 for _ in log.samples())
    summary = log.summary()
    assert n > 0 and summary["bad_crc"] > 0
    assert sum(summary["counts"].values()) == summary["messages"]
    assert any("bad frames skipped" in w for w in log.warnings())


def test_an_empty_file_is_a_data_error(tmp_path: Path) -> None:
    empty = tmp_path / "empty.tlog"
    empty.write_bytes(b"")
    log = open_log(empty)
    assert list(log.samples()) == []
    with pytest.raises(DataError, match="no MAVLink message"):
        log.summary()
