"""The trim history's SQLite file: where it is, how it is opened, its schema and migrations.

One file per machine (``<data dir>/trimd.db``, see :func:`trimd.app.files.data_dir`),
opened in WAL journal mode: readers never block the writer, a writer killed mid-write
(``kill -9``) leaves the last committed transaction intact, and every record is written
in one transaction. The schema version is SQLite's ``PRAGMA user_version``; a file at
version k is brought to :data:`SCHEMA_VERSION` by running ``MIGRATIONS[k:]`` in order,
each in one transaction with its version bump, so an interrupted migration leaves the
file at a version it really has.

Times are seconds since the Unix epoch (UTC) [s]; JSON columns hold the shapes of
:func:`trimd.core.estimate_json.estimate_to_dict` and
:func:`trimd.ballast.propose.proposal_to_dict`, or a caller's dict of values. A
correction (:mod:`trimd.ballast.correct`) is stored as the measured vehicle's estimate and
its proposal, with the id of the verify hold or of the float check (``float_checks``: its
result as :func:`trimd.core.floating.float_to_dict` gives it, and the session log) it
came from. A level hold of a trim or a
verify hold is stored summarised for calibration (``level_holds``: the hold as
:func:`trimd.core.calibration.calibration_hold` gives it, in
:func:`trimd.core.calibration_json.hold_to_dict`'s shape, whose ``outputs`` key — the
thruster outputs' histograms — records made before 2026-11-29 lack; the vehicle's q and
its covariance then, the ballast installed then and the trim's or verify hold's record
id), and each known ballast change between two of them is a calibration experiment
(``calibration_experiments``: the experiment as
:func:`trimd.core.calibration_json.experiment_to_dict` gives it, accepted or rejected and
why, and the gains and band edges after it), as is a float check right after a level
hold (a float reference, ``"kind": "float"`` in its JSON, which records before
2026-11-30 never have: no new table); the vehicle's calibration is recomputed from these
(docs/method.md §7).
"""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

from trimd.app.files import data_dir
from trimd.core.errors import DataError

__all__ = ["MIGRATIONS", "SCHEMA_VERSION", "connect", "default_db_path", "migrate"]

#: Schema steps: MIGRATIONS[k] takes a file from version k to version k + 1.
MIGRATIONS: tuple[tuple[str, ...], ...] = (
    # v1: trims, watch segments and alerts, installed ballast
    ("CREATE TABLE trims (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "profile TEXT NOT NULL, t_unix REAL NOT NULL, estimate_json TEXT NOT NULL, "
     "proposal_json TEXT, log_path TEXT)",
     "CREATE TABLE watch_segments (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, values_json TEXT NOT NULL)",
     "CREATE TABLE alerts (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, values_json TEXT NOT NULL)",
     "CREATE TABLE installs (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "profile TEXT NOT NULL, t_unix REAL NOT NULL, source TEXT NOT NULL "
     "CHECK (source IN ('proposal', 'edited', 'profile')))",
     "CREATE TABLE installed_pieces (install_id INTEGER NOT NULL REFERENCES installs(id), "
     "slot TEXT NOT NULL, piece TEXT NOT NULL, count INTEGER NOT NULL CHECK (count > 0))"),
    # v2: verify outcomes, and the per-vehicle time indexes every listing reads by
    ("CREATE TABLE verifications (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, values_json TEXT NOT NULL)",
     *(f"CREATE INDEX {t}_by_vehicle ON {t} (vehicle, t_unix)"
       for t in ("trims", "watch_segments", "alerts", "installs", "verifications")),
     "CREATE INDEX installed_pieces_by_install ON installed_pieces (install_id)"),
    # v3: corrections proposed from a verify hold, each linked to its verify hold
    ("CREATE TABLE corrections (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, verify_id INTEGER NOT NULL REFERENCES verifications(id), "
     "estimate_json TEXT NOT NULL, proposal_json TEXT NOT NULL)",
     "CREATE INDEX corrections_by_vehicle ON corrections (vehicle, t_unix)"),
    # v4: level holds summarised for calibration, and the calibration experiments
    ("CREATE TABLE level_holds (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, values_json TEXT NOT NULL)",
     "CREATE TABLE calibration_experiments (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, values_json TEXT NOT NULL)",
     *(f"CREATE INDEX {t}_by_vehicle ON {t} (vehicle, t_unix)"
       for t in ("level_holds", "calibration_experiments"))),
    # v5: float checks, and corrections from a float check as from a verify hold (the
    # corrections table rebuilt: a correction comes from exactly one of the two)
    ("CREATE TABLE float_checks (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, values_json TEXT NOT NULL)",
     "CREATE INDEX float_checks_by_vehicle ON float_checks (vehicle, t_unix)",
     "CREATE TABLE corrections_v5 (id INTEGER PRIMARY KEY, vehicle TEXT NOT NULL, "
     "t_unix REAL NOT NULL, verify_id INTEGER REFERENCES verifications(id), "
     "float_id INTEGER REFERENCES float_checks(id), estimate_json TEXT NOT NULL, "
     "proposal_json TEXT NOT NULL, CHECK ((verify_id IS NULL) <> (float_id IS NULL)))",
     "INSERT INTO corrections_v5 (id, vehicle, t_unix, verify_id, estimate_json, "
     "proposal_json) SELECT id, vehicle, t_unix, verify_id, estimate_json, proposal_json "
     "FROM corrections",
     "DROP TABLE corrections",
     "ALTER TABLE corrections_v5 RENAME TO corrections",
     "CREATE INDEX corrections_by_vehicle ON corrections (vehicle, t_unix)"),
)
SCHEMA_VERSION = len(MIGRATIONS)
#: How long a writer waits for another's lock before it gives up [s].
BUSY_TIMEOUT_S = 10.0
#: How long a migration waits for the lock before it re-reads the version [s].
STEP_WAIT_S = 0.05


def default_db_path() -> Path:
    """``<data dir>/trimd.db``: ``$TRIMD_DATA_DIR/trimd.db``, else
    ``~/.local/share/trimd/trimd.db`` (``$XDG_DATA_HOME/trimd`` when that is set)."""
    return data_dir() / "trimd.db"


def _wal(conn: sqlite3.Connection) -> None:
    """Put the file in WAL journal mode, waiting up to :data:`BUSY_TIMEOUT_S` for others.

    While a new file is created by two processes at once (the watch and the service
    starting together), each switch reads the header and then wants to write it; SQLite
    answers the second "database is locked" at once, without its busy handler (waiting
    could deadlock), so the switch is retried here until the other has committed."""
    deadline = time.monotonic() + BUSY_TIMEOUT_S
    while True:
        try:
            conn.execute("PRAGMA journal_mode = WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.01)


def _version(conn: sqlite3.Connection) -> int:
    return int(conn.execute("PRAGMA user_version").fetchone()[0])


def _lock_for_step(conn: sqlite3.Connection, version: int) -> bool:
    """Take the write lock to run migration ``version``; False (no lock) when another
    connection has run it meanwhile.

    The lock is asked for in turns of :data:`STEP_WAIT_S`, the version re-read (a read,
    which WAL never blocks) between them, for up to :data:`BUSY_TIMEOUT_S` in all: a
    process that migrates the file and then stores record after record leaves the lock
    free for microseconds at a time, and one long wait would queue for a lock this
    connection no longer needs until SQLite gave up ("database is locked")."""
    deadline = time.monotonic() + BUSY_TIMEOUT_S
    conn.execute(f"PRAGMA busy_timeout = {round(STEP_WAIT_S * 1000)}")
    try:
        while _version(conn) <= version:
            try:
                conn.execute("BEGIN IMMEDIATE")
                return True
            except sqlite3.OperationalError as exc:
                if "locked" not in str(exc) or time.monotonic() > deadline:
                    raise
        return False
    finally:
        conn.execute(f"PRAGMA busy_timeout = {round(BUSY_TIMEOUT_S * 1000)}")


def migrate(conn: sqlite3.Connection, upto: int = SCHEMA_VERSION) -> int:
    """Bring the file to version ``upto`` (each step one transaction); its old version.

    DataError when the file is newer than this trimd knows."""
    old = _version(conn)
    if old > SCHEMA_VERSION:
        raise DataError(f"the trim history has schema version {old}; this trimd knows up to "
                        f"{SCHEMA_VERSION}: update trimd")
    for version in range(old, upto):
        if not _lock_for_step(conn, version):
            continue
        try:
            if _version(conn) == version:
                for statement in MIGRATIONS[version]:
                    conn.execute(statement)
                conn.execute(f"PRAGMA user_version = {version + 1}")
            conn.execute("COMMIT")
        except BaseException:
            conn.execute("ROLLBACK")
            raise
    return old


def connect(path: str | Path, *, upto: int = SCHEMA_VERSION) -> sqlite3.Connection:
    """Open (creating it and its folder if needed) and migrate the history at ``path``.

    Autocommit mode: every write states its own transaction (``BEGIN IMMEDIATE``).
    DataError naming the file when it cannot be opened or is no SQLite database."""
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        conn = sqlite3.connect(p, timeout=BUSY_TIMEOUT_S, isolation_level=None)
    except (OSError, sqlite3.Error) as exc:
        raise DataError(f"{p}: cannot open the trim history ({exc})") from None
    try:
        _wal(conn)
        conn.execute("PRAGMA foreign_keys = ON")
        conn.execute("PRAGMA synchronous = FULL")
        migrate(conn, upto)
    except sqlite3.OperationalError as exc:
        conn.close()
        raise DataError(f"{p}: cannot open the trim history ({exc})") from None
    except sqlite3.DatabaseError as exc:
        conn.close()
        raise DataError(f"{p}: not a trim history ({exc})") from None
    except BaseException:
        conn.close()
        raise
    return conn
