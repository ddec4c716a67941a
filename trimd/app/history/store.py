"""Reading and writing the trim history: one :class:`History` per open file.

Every record is keyed by its vehicle (:func:`vehicle_key`) and a time [s since the Unix
epoch, UTC], and written in one transaction: a record is in the file whole or not at all.
The watch and the verify hold write through :meth:`History.record_watch_segment`,
:meth:`History.record_alert` and :meth:`History.record_verify` (a dict of JSON values
each; a verify hold's correction in the same transaction, linked to it); ``trimd run``
through :meth:`History.record_trim`; ``trimd ballast apply`` through
:meth:`History.record_installed`.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Literal

from trimd.app.history.schema import connect, default_db_path
from trimd.core.errors import DataError
from trimd.core.jsonsafe import json_finite
from trimd.core.profile import InstalledPiece

__all__ = ["CorrectionRecord", "EventRecord", "History", "InstallRecord", "TrimRecord",
           "vehicle_key"]

Source = Literal["proposal", "edited", "profile"]
_EVENT_TABLES = ("watch_segments", "alerts", "verifications", "level_holds",
                 "calibration_experiments", "float_checks")


def vehicle_key(profile_name: str, vehicle_id: str | int | None = None,
                name: str | None = None) -> str:
    """The key a vehicle's records go under: ``name`` when the operator gives one
    (``--vehicle``), else ``<profile>#<id>`` with the vehicle's MAVLink system id or serial
    id when known, else the profile's name."""
    if name:
        return name
    return f"{profile_name}#{vehicle_id}" if vehicle_id is not None else profile_name


@dataclass(frozen=True)
class TrimRecord:
    """One ``trimd run`` result: the estimate and proposal as their JSON dicts."""

    id: int
    vehicle: str
    profile: str
    t_unix: float
    estimate: dict[str, Any]
    proposal: dict[str, Any] | None
    log_path: str | None


@dataclass(frozen=True)
class EventRecord:
    """A watch segment, an alert or a verify outcome: a time and the caller's values."""

    id: int
    vehicle: str
    t_unix: float
    values: dict[str, Any]


@dataclass(frozen=True)
class CorrectionRecord:
    """A verify hold's or a float check's correction: the vehicle as it measured it
    (``estimate``, the ``estimate_to_dict`` shape) and the proposal from the ballast
    installed then (``proposal_to_dict``); ``verify_id`` is the verify hold's record,
    ``float_id`` the float check's (the other None)."""

    id: int
    vehicle: str
    t_unix: float
    verify_id: int | None
    estimate: dict[str, Any]
    proposal: dict[str, Any]
    float_id: int | None = None


@dataclass(frozen=True)
class InstallRecord:
    """What was installed on the vehicle at ``t_unix``: the whole configuration then."""

    id: int
    vehicle: str
    profile: str
    t_unix: float
    source: Source
    pieces: tuple[InstalledPiece, ...]


def _json(values: object) -> str:
    """Strict JSON of ``values``; an undefined number is stored as null."""
    return json.dumps(json_finite(values), allow_nan=False, sort_keys=True)


class History:
    """An open trim history (``with History(path) as h: ...``). ``path`` defaults to
    :func:`~trimd.app.history.schema.default_db_path`; the file and its folder are
    created and migrated when needed."""

    def __init__(self, path: str | Path | None = None) -> None:
        self.path = Path(path) if path is not None else default_db_path()
        self._conn = connect(self.path)

    def __enter__(self) -> History:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        self._conn.close()

    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        """One transaction: all of it is written, or nothing (DataError naming the file
        when SQLite refuses: a full disk, a lock held too long, a bad value)."""
        try:
            self._conn.execute("BEGIN IMMEDIATE")
            try:
                yield self._conn
            except BaseException:
                self._conn.execute("ROLLBACK")
                raise
            self._conn.execute("COMMIT")
        except sqlite3.Error as exc:
            raise DataError(f"{self.path}: cannot write the trim history ({exc})") from None

    # writes ---------------------------------------------------------------------------

    def record_trim(self, vehicle: str, profile: str, t_unix: float,
                    estimate: dict[str, Any], proposal: dict[str, Any] | None = None,
                    log_path: str | None = None) -> int:
        """Store a trim's estimate (``estimate_to_dict``, covariance included), its proposal
        (``proposal_to_dict``) and session log path; the record's id."""
        with self._transaction() as c:
            cur = c.execute("INSERT INTO trims (vehicle, profile, t_unix, estimate_json, "
                            "proposal_json, log_path) VALUES (?, ?, ?, ?, ?, ?)",
                            (vehicle, profile, t_unix, _json(estimate),
                             None if proposal is None else _json(proposal), log_path))
        return int(cur.lastrowid or 0)

    @staticmethod
    def _insert_event(c: sqlite3.Connection, table: str, vehicle: str, t_unix: float,
                      values: dict[str, Any]) -> int:
        cur = c.execute(f"INSERT INTO {table} (vehicle, t_unix, values_json) "
                        "VALUES (?, ?, ?)", (vehicle, t_unix, _json(values)))
        return int(cur.lastrowid or 0)

    def _event(self, table: str, vehicle: str, t_unix: float, values: dict[str, Any]) -> int:
        with self._transaction() as c:
            return self._insert_event(c, table, vehicle, t_unix, values)

    def record_watch_segment(self, vehicle: str, t_unix: float, values: dict[str, Any]) -> int:
        """Store one steady segment of a watch: any JSON values; ``net_force_N`` and
        ``net_force_std_N`` (W − B and its 1σ [N]) are what ``trimd history --plot``
        draws, ``net_moment_Nm``/``net_moment_std_Nm`` the natural names for the rest."""
        return self._event("watch_segments", vehicle, t_unix, values)

    def record_alert(self, vehicle: str, t_unix: float, values: dict[str, Any]) -> int:
        """Store one watch alert; a ``"text"`` value is what ``trimd history`` shows."""
        return self._event("alerts", vehicle, t_unix, values)

    def record_watch(self, vehicle: str, t_unix: float, values: dict[str, Any]) -> int:
        """Store a watch record's ``to_dict``: an alert (``type`` ``alert``) or a segment."""
        record = self.record_alert if values.get("type") == "alert" else self.record_watch_segment
        return record(vehicle, t_unix, values)

    def record_verify(self, vehicle: str, t_unix: float, values: dict[str, Any],
                      correction: tuple[dict[str, Any], dict[str, Any]] | None = None) -> int:
        """Store one verify hold's outcome (measured against predicted residual trim) and,
        in the same transaction, its ``correction`` (the measured vehicle's estimate and
        the proposal, as JSON dicts) linked to it; the verify hold's record id."""
        return self._with_correction("verifications", "verify_id", vehicle, t_unix, values,
                                     correction)

    def record_float(self, vehicle: str, t_unix: float, values: dict[str, Any],
                     correction: tuple[dict[str, Any], dict[str, Any]] | None = None) -> int:
        """Store one float check's result (``float_to_dict`` and its session log) and, in
        the same transaction, its ``correction`` linked to it; the float check's id."""
        return self._with_correction("float_checks", "float_id", vehicle, t_unix, values,
                                     correction)

    def _with_correction(self, table: str, link: str, vehicle: str, t_unix: float,
                         values: dict[str, Any],
                         correction: tuple[dict[str, Any], dict[str, Any]] | None) -> int:
        """One record of ``table`` and the correction (estimate, proposal) that refers to
        it by the column ``link``, in one transaction; the record's id."""
        with self._transaction() as c:
            record = self._insert_event(c, table, vehicle, t_unix, values)
            if correction is not None:
                c.execute(f"INSERT INTO corrections (vehicle, t_unix, {link}, "
                          "estimate_json, proposal_json) VALUES (?, ?, ?, ?, ?)",
                          (vehicle, t_unix, record, *map(_json, correction)))
        return record

    def record_level_hold(self, vehicle: str, t_unix: float, values: dict[str, Any]) -> int:
        """Store a level hold summarised for calibration (``trimd.app.history.calibration``)."""
        return self._event("level_holds", vehicle, t_unix, values)

    def record_experiment(self, vehicle: str, t_unix: float, values: dict[str, Any]) -> int:
        """Store a calibration experiment and what became of it."""
        return self._event("calibration_experiments", vehicle, t_unix, values)

    def record_installed(self, vehicle: str, profile: str, t_unix: float, source: Source,
                         pieces: Sequence[InstalledPiece]) -> int:
        """Store the whole ballast configuration now on the vehicle (pieces already checked
        against the profile: :meth:`Profile.resolve_installed`); an empty one is a record
        too (everything taken off)."""
        with self._transaction() as c:
            cur = c.execute("INSERT INTO installs (vehicle, profile, t_unix, source) "
                            "VALUES (?, ?, ?, ?)", (vehicle, profile, t_unix, source))
            install = int(cur.lastrowid or 0)
            c.executemany("INSERT INTO installed_pieces (install_id, slot, piece, count) "
                          "VALUES (?, ?, ?, ?)",
                          [(install, p.slot, p.piece, p.count) for p in pieces if p.count > 0])
        return install

    # reads ----------------------------------------------------------------------------

    def vehicles(self) -> list[str]:
        """Every vehicle with a record, sorted."""
        rows = self._conn.execute(
            " UNION ".join(f"SELECT vehicle FROM {t}" for t in
                           ("trims", "installs", "corrections", *_EVENT_TABLES))
            + " ORDER BY vehicle")
        return [str(r[0]) for r in rows]

    def trims(self, vehicle: str) -> list[TrimRecord]:
        """The vehicle's trims, oldest first."""
        rows = self._conn.execute(
            "SELECT id, vehicle, profile, t_unix, estimate_json, proposal_json, log_path "
            "FROM trims WHERE vehicle = ? ORDER BY t_unix, id", (vehicle,))
        return [TrimRecord(r[0], r[1], r[2], r[3], json.loads(r[4]),
                           None if r[5] is None else json.loads(r[5]), r[6]) for r in rows]

    def _events(self, table: str, vehicle: str, dive: str | None = None) -> list[EventRecord]:
        where = "" if dive is None else " AND json_extract(values_json, '$.dive') = ?"
        rows = self._conn.execute(f"SELECT id, vehicle, t_unix, values_json FROM {table} "
                                  f"WHERE vehicle = ?{where} ORDER BY t_unix, id",
                                  (vehicle,) if dive is None else (vehicle, dive))
        return [EventRecord(r[0], r[1], r[2], json.loads(r[3])) for r in rows]

    def watch_segments(self, vehicle: str, dive: str | None = None) -> list[EventRecord]:
        """The vehicle's watch segments (of the dive ``dive`` of ``trimd serve`` when
        given), oldest first."""
        return self._events("watch_segments", vehicle, dive)

    def alerts(self, vehicle: str, dive: str | None = None) -> list[EventRecord]:
        """The vehicle's watch alerts (of the dive ``dive`` when given), oldest first."""
        return self._events("alerts", vehicle, dive)

    def dives(self, vehicle: str) -> list[str]:
        """The ids of the dives (``trimd serve``) with a watch record of the vehicle, sorted."""
        rows = self._conn.execute(
            " UNION ".join(f"SELECT json_extract(values_json, '$.dive') AS d FROM {t} "
                           "WHERE vehicle = ? AND d IS NOT NULL"
                           for t in ("watch_segments", "alerts")) + " ORDER BY d",
            (vehicle, vehicle))
        return [str(r[0]) for r in rows]

    def verifications(self, vehicle: str) -> list[EventRecord]:
        """The vehicle's verify outcomes, oldest first."""
        return self._events("verifications", vehicle)

    def float_checks(self, vehicle: str) -> list[EventRecord]:
        """The vehicle's float checks, oldest first."""
        return self._events("float_checks", vehicle)

    def level_holds(self, vehicle: str) -> list[EventRecord]:
        """The vehicle's level holds summarised for calibration, oldest first."""
        return self._events("level_holds", vehicle)

    def experiments(self, vehicle: str) -> list[EventRecord]:
        """The vehicle's calibration experiments, oldest first."""
        return self._events("calibration_experiments", vehicle)

    def corrections(self, vehicle: str) -> list[CorrectionRecord]:
        """The vehicle's corrections (its verify holds' and float checks'), oldest first."""
        rows = self._conn.execute(
            "SELECT id, vehicle, t_unix, verify_id, estimate_json, proposal_json, float_id "
            "FROM corrections WHERE vehicle = ? ORDER BY t_unix, id", (vehicle,))
        return [CorrectionRecord(r[0], r[1], r[2], r[3], json.loads(r[4]), json.loads(r[5]),
                                 r[6]) for r in rows]

    def installs(self, vehicle: str) -> list[InstallRecord]:
        """Every ballast configuration recorded for the vehicle, oldest first."""
        rows = self._conn.execute("SELECT id, vehicle, profile, t_unix, source FROM installs "
                                  "WHERE vehicle = ? ORDER BY t_unix, id", (vehicle,)).fetchall()
        out = []
        for r in rows:
            pieces = self._conn.execute("SELECT slot, piece, count FROM installed_pieces "
                                        "WHERE install_id = ? ORDER BY rowid", (r[0],))
            out.append(InstallRecord(r[0], r[1], r[2], r[3], r[4],
                                     tuple(InstalledPiece(*p) for p in pieces)))
        return out

    def installed(self, vehicle: str) -> InstallRecord | None:
        """The vehicle's latest ballast configuration, None when none was recorded."""
        records = self.installs(vehicle)
        return records[-1] if records else None
