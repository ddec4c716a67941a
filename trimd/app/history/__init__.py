"""The vehicle's trim history: an SQLite file of trims, watch segments and alerts,
installed ballast and verify outcomes (docs/operator.md, "The trim history")."""

from trimd.app.history.schema import SCHEMA_VERSION, default_db_path
from trimd.app.history.store import (
    EventRecord,
    History,
    InstallRecord,
    TrimRecord,
    vehicle_key,
)

__all__ = ["SCHEMA_VERSION", "EventRecord", "History", "InstallRecord", "TrimRecord",
           "default_db_path", "vehicle_key"]
