"""The trim history file: schema and migrations, concurrent readers, a writer killed mid-write."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.helpers import REPO
from trimd.app.history import SCHEMA_VERSION, History, default_db_path, vehicle_key
from trimd.app.history.schema import MIGRATIONS, connect, migrate
from trimd.core.errors import DataError
from trimd.core.profile import InstalledPiece

PIECES = [InstalledPiece(f"slot-{i}", "lead-200g", i + 1) for i in range(5)]
ESTIMATE = {"net_force_N": 1.5, "cov_net": [[0.01, 0, 0, 0], [0, 0.02, 0, 0],
                                             [0, 0, 0.02, 0], [0, 0, 0, 0.03]]}

#: A writer that stores trims and five-piece installs as fast as it can, forever.
WRITER = """
import sys, time
from trimd.app.history import History
from trimd.core.profile import InstalledPiece
h = History(sys.argv[1])
pieces = [InstalledPiece(f"slot-{i}", "lead-200g", i + 1) for i in range(5)]
k = 0
while True:
    h.record_installed("rov", "bluerov2-heavy", time.time(), "proposal", pieces)
    h.record_trim("rov", "bluerov2-heavy", time.time(), {"k": k, "pad": "x" * 20000})
    k += 1
"""


def _writer(path: Path) -> subprocess.Popen[bytes]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.Popen([sys.executable, "-c", WRITER, str(path)], env=env)


def _wait_for_records(path: Path, n: int) -> None:
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        if path.exists():
            with History(path) as h:
                if len(h.trims("rov")) >= n:
                    return
        time.sleep(0.05)
    raise AssertionError("the writer stored nothing")


def test_default_path_is_in_the_data_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                         ) -> None:
    monkeypatch.setenv("TRIMD_DATA_DIR", str(tmp_path))
    assert default_db_path() == tmp_path / "trimd.db"
    monkeypatch.delenv("TRIMD_DATA_DIR")
    monkeypatch.delenv("XDG_DATA_HOME", raising=False)
    assert default_db_path() == Path.home() / ".local/share/trimd/trimd.db"


def test_a_new_file_has_the_schema_in_wal_mode(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "trimd.db"
    History(path).close()
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION == 5
    assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    assert {"trims", "watch_segments", "alerts", "installs", "installed_pieces",
            "verifications", "corrections"} <= tables


def test_records_read_back_per_vehicle(tmp_path: Path) -> None:
    with History(tmp_path / "h.db") as h:
        h.record_trim("a", "bluerov2-heavy", 100.0, ESTIMATE, {"method": "milp"}, "/x.tlog")
        h.record_trim("b", "bluerov2-heavy", 50.0, ESTIMATE)
        h.record_installed("a", "bluerov2-heavy", 110.0, "proposal", PIECES)
        h.record_installed("a", "bluerov2-heavy", 120.0, "edited", PIECES[:2])
        h.record_watch_segment("a", 130.0, {"net_force_N": 1.4})
        h.record_alert("a", 140.0, {"text": "heavier by 2.1 ± 0.3 N"})
        h.record_verify("a", 150.0, {"residual_roll_deg": 0.1})
        assert h.vehicles() == ["a", "b"]
        [trim] = h.trims("a")
        assert (trim.estimate, trim.proposal, trim.log_path) == (
            ESTIMATE, {"method": "milp"}, "/x.tlog")
        assert h.trims("b")[0].proposal is None
        latest = h.installed("a")
        assert latest is not None and latest.source == "edited"
        assert latest.pieces == tuple(PIECES[:2])
        assert [len(r.pieces) for r in h.installs("a")] == [5, 2]
        assert h.installed("b") is None
        assert h.alerts("a")[0].values["text"].startswith("heavier")
        assert h.watch_segments("a")[0].t_unix == 130.0
        assert h.verifications("a")[0].values == {"residual_roll_deg": 0.1}


def test_a_failed_write_leaves_nothing_and_undefined_numbers_are_null(tmp_path: Path) -> None:
    with History(tmp_path / "h.db") as h:
        bad = [*PIECES[:2], InstalledPiece("slot-x", "lead-200g", 0)]
        h.record_installed("a", "p", 1.0, "proposal", bad)  # a zero count is dropped
        with pytest.raises(DataError, match="cannot write the trim history"):
            h.record_installed("a", "p", 2.0, "bought", PIECES)  # type: ignore[arg-type]
        assert [len(r.pieces) for r in h.installs("a")] == [2]  # not the first pieces either
        h.record_alert("a", 3.0, {"change_N": float("nan"), "x": [1.0, float("inf")]})
        assert h.alerts("a")[0].values == {"change_N": None, "x": [1.0, None]}


def test_vehicle_keys() -> None:
    assert vehicle_key("bluerov2-heavy") == "bluerov2-heavy"
    assert vehicle_key("bluerov2-heavy", 3) == "bluerov2-heavy#3"
    assert vehicle_key("bluerov2-heavy", 3, "yellow-rov") == "yellow-rov"


def test_a_version_1_file_migrates_and_keeps_its_records(tmp_path: Path) -> None:
    path = tmp_path / "old.db"
    old = connect(path, upto=1)
    assert old.execute("PRAGMA user_version").fetchone()[0] == 1
    old.execute("INSERT INTO trims (vehicle, profile, t_unix, estimate_json) "
                "VALUES ('rov', 'p', 1.0, ?)", (json.dumps(ESTIMATE),))
    with pytest.raises(sqlite3.OperationalError):
        old.execute("SELECT * FROM verifications")
    old.close()
    with History(path) as h:
        assert h.trims("rov")[0].estimate == ESTIMATE
        h.record_verify("rov", 2.0, {"ok": True})
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    indexes = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='index'")}
    assert "trims_by_vehicle" in indexes
    assert migrate(conn) == SCHEMA_VERSION  # nothing left to do


def test_a_version_2_file_migrates_and_takes_corrections(tmp_path: Path) -> None:
    """Version 3 adds the corrections, each linked to its verify hold: a file of version 2
    keeps its trims and verify holds, and a correction stored after links to its own."""
    path = tmp_path / "v2.db"
    old = connect(path, upto=2)
    old.execute("INSERT INTO trims (vehicle, profile, t_unix, estimate_json) "
                "VALUES ('rov', 'p', 1.0, ?)", (json.dumps(ESTIMATE),))
    old.execute("INSERT INTO verifications (vehicle, t_unix, values_json) "
                "VALUES ('rov', 2.0, '{\"level\": false}')")
    with pytest.raises(sqlite3.OperationalError):
        old.execute("SELECT * FROM corrections")
    old.close()
    with History(path) as h:
        assert h.trims("rov")[0].estimate == ESTIMATE
        assert h.verifications("rov")[0].values == {"level": False}
        assert h.corrections("rov") == []
        verify = h.record_verify("rov", 3.0, {"level": False},
                                 correction=(ESTIMATE, {"method": "milp"}))
        corrections = h.corrections("rov")
        assert h.vehicles() == ["rov"]
    assert [(c.verify_id, c.estimate, c.proposal) for c in corrections] == [
        (verify, ESTIMATE, {"method": "milp"})]
    assert verify == 2  # the file's second verify hold
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION == 5
    assert conn.execute("PRAGMA foreign_key_check").fetchall() == []


def test_a_version_4_file_migrates_and_takes_float_checks(tmp_path: Path) -> None:
    """Version 5 adds the float checks and links a correction to a verify hold or to a
    float check: a version-4 file keeps its corrections (linked to their verify holds), a
    float check stored after carries its own, and a correction that names both or
    neither is refused by the file itself."""
    path = tmp_path / "v4.db"
    old = connect(path, upto=4)
    old.execute("INSERT INTO verifications (vehicle, t_unix, values_json) "
                "VALUES ('rov', 2.0, '{\"level\": false}')")
    old.execute("INSERT INTO corrections (vehicle, t_unix, verify_id, estimate_json, "
                "proposal_json) VALUES ('rov', 2.0, 1, ?, '{\"method\": \"milp\"}')",
                (json.dumps(ESTIMATE),))
    old.close()
    with History(path) as h:
        floated = h.record_float("rov", 3.0, {"message": "floats NOT level"},
                                 correction=(ESTIMATE, {"method": "float"}))
        assert [(c.verify_id, c.float_id, c.proposal["method"]) for c in h.corrections("rov")
                ] == [(1, None, "milp"), (None, floated, "float")]
        assert [r.values for r in h.float_checks("rov")] == [{"message": "floats NOT level"}]
    conn = sqlite3.connect(path)
    conn.execute("PRAGMA foreign_keys = ON")
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION == 5
    assert conn.execute("PRAGMA foreign_key_check").fetchall() == []
    for link in ("NULL, NULL", "1, 1"):
        with pytest.raises(sqlite3.IntegrityError):
            conn.execute("INSERT INTO corrections (vehicle, t_unix, verify_id, float_id, "
                         f"estimate_json, proposal_json) VALUES ('rov', 4.0, {link}, '{{}}', "
                         "'{}')")


def test_a_newer_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "new.db"
    conn = sqlite3.connect(path)
    conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    conn.close()
    with pytest.raises(DataError, match="update trimd"):
        History(path)


def test_not_a_database(tmp_path: Path) -> None:
    path = tmp_path / "junk.db"
    path.write_bytes(b"this is not sqlite" * 100)
    with pytest.raises(DataError, match="not a trim history"):
        History(path)


def test_a_reader_sees_a_snapshot_while_another_connection_writes(tmp_path: Path) -> None:
    path = tmp_path / "h.db"
    with History(path) as writer, History(path) as reader:
        writer.record_trim("rov", "p", 1.0, ESTIMATE)
        conn = sqlite3.connect(path, isolation_level=None)
        conn.execute("BEGIN")
        assert conn.execute("SELECT count(*) FROM trims").fetchone()[0] == 1
        writer.record_trim("rov", "p", 2.0, ESTIMATE)  # WAL: the open read does not block it
        assert conn.execute("SELECT count(*) FROM trims").fetchone()[0] == 1  # its snapshot
        conn.execute("COMMIT")
        assert conn.execute("SELECT count(*) FROM trims").fetchone()[0] == 2
        assert len(reader.trims("rov")) == 2


def test_readers_see_only_whole_records_while_a_process_writes(tmp_path: Path) -> None:
    path = tmp_path / "h.db"
    proc = _writer(path)
    try:
        _wait_for_records(path, 1)
        seen: list[int] = []
        deadline = time.monotonic() + 60.0
        with History(path) as h:
            while len(set(seen)) < 5 and time.monotonic() < deadline:  # reads as it writes
                installs = h.installs("rov")
                assert all(r.pieces == tuple(PIECES) for r in installs)
                seen.append(len(installs))
        assert seen == sorted(seen) and len(set(seen)) == 5
    finally:
        proc.kill()
        proc.wait()


def _open_together(path: Path, n: int) -> list[DataError]:
    """Open a new history at ``path`` from ``n`` threads released at once; their errors."""
    start = threading.Barrier(n)
    errors: list[DataError] = []

    def open_it() -> None:
        start.wait()
        try:
            connect(path).close()
        except DataError as exc:
            errors.append(exc)

    threads = [threading.Thread(target=open_it) for _ in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return errors


def test_processes_creating_the_file_at_once_all_open_it(tmp_path: Path) -> None:
    # eight connections switch a new file to WAL together, a hundred times: before the
    # switch waited for the others, 6 in 100 rounds had one refused "database is locked"
    for k in range(100):
        path = tmp_path / f"h{k}.db"
        assert _open_together(path, 8) == []
        with History(path) as h:
            assert h.trims("rov") == []


def test_opening_while_another_migrates_then_writes_without_pause(tmp_path: Path) -> None:
    # the reader reads version 4 while the other holds the lock; the other migrates, then
    # stores record after record with the lock free for microseconds between them. Before
    # the reader re-read the version between short waits it queued for a lock it no longer
    # needed and was refused "database is locked" after 10 s (once in CI, in the test above)
    path = tmp_path / "h.db"
    connect(path, upto=4).close()
    other = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    other.execute("BEGIN IMMEDIATE")
    stop = threading.Event()

    def migrate_then_write() -> None:
        time.sleep(0.3)  # the reader is waiting for the lock by now
        for statement in MIGRATIONS[4]:
            other.execute(statement)
        other.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
        other.execute("COMMIT")
        while not stop.is_set():
            other.execute("BEGIN IMMEDIATE")
            time.sleep(0.02)
            other.execute("COMMIT")

    thread = threading.Thread(target=migrate_then_write)
    thread.start()
    try:
        with History(path) as h:
            assert h.trims("rov") == []
    finally:
        stop.set()
        thread.join()
        other.close()


def test_kill_9_mid_write_leaves_the_file_intact(tmp_path: Path) -> None:
    path = tmp_path / "h.db"
    for kills in range(1, 4):  # three kills at whatever point the writer has reached
        proc = _writer(path)
        _wait_for_records(path, 5)
        time.sleep(0.1)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        assert proc.returncode == -signal.SIGKILL
        conn = sqlite3.connect(path)
        assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        orphans = conn.execute("SELECT count(*) FROM installed_pieces WHERE install_id NOT IN "
                               "(SELECT id FROM installs)").fetchone()[0]
        conn.close()
        assert orphans == 0
        with History(path) as h:
            assert all(r.pieces == tuple(PIECES) for r in h.installs("rov"))
            trims = h.trims("rov")
            assert all(len(t.estimate["pad"]) == 20000 for t in trims)
            # each kill cut at most one install-then-trim pair in two
            assert 0 <= len(h.installs("rov")) - len(trims) <= kills


def test_the_plot_draws_trims_watch_segments_and_alerts(tmp_path: Path) -> None:
    from trimd.app.history.plot import write_history_plot

    estimate = {**ESTIMATE, "cg_m": [0.001, 0.0, 0.005], "cg_std_m": [1e-4, 1e-4, 3e-4]}
    with History(tmp_path / "h.db") as h:
        for k in range(3):
            h.record_trim("rov", "p", 1.8e9 + 86400 * k, estimate)
        h.record_watch_segment("rov", 1.8e9 + 1000, {"net_force_N": 1.6,
                                                     "net_force_std_N": 0.2})
        h.record_watch_segment("rov", 1.8e9 + 2000, {"text": "no force"})
        h.record_alert("rov", 1.8e9 + 3000, {"text": "heavier"})
        h.record_installed("rov", "p", 1.8e9 + 4000, "proposal", PIECES)
        png = tmp_path / "h.png"
        assert write_history_plot(h, "rov", png) == 3
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 10_000


def test_opening_waits_for_another_process_creating_the_file(tmp_path: Path) -> None:
    """A new file still in rollback-journal mode, held exclusively by another connection
    for a moment: opening it waits and switches it to WAL rather than failing."""
    import threading

    path = tmp_path / "h.db"
    other = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    other.execute("BEGIN EXCLUSIVE")
    other.execute("CREATE TABLE scratch (x)")
    releaser = threading.Timer(0.5, lambda: other.execute("COMMIT"))
    releaser.start()
    try:
        with History(path) as h:
            h.record_alert("rov", 1.0, {"text": "ok"})
            assert len(h.alerts("rov")) == 1
    finally:
        releaser.join()
        other.close()
    assert sqlite3.connect(path).execute("PRAGMA journal_mode").fetchone()[0] == "wal"
