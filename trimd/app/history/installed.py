"""The ballast on a vehicle now: the latest configuration the history holds for it, else
what its profile declares (``ballast.installed``)."""

from __future__ import annotations

from pathlib import Path

from trimd.app.history.store import History
from trimd.core.profile import InstalledPiece, Profile

__all__ = ["current_installed"]


def current_installed(db: str | Path | None, vehicle: str, profile: Profile
                      ) -> tuple[tuple[InstalledPiece, ...], str]:
    """The vehicle's installed ballast (checked against ``profile``) and where it comes
    from, in words. ``db`` None, or a file that does not exist, means the profile's (the
    file is not created for reading). ProfileError when a recorded slot or piece is not
    in the profile (it was renamed: record the configuration again)."""
    if db is not None and Path(db).exists():
        with History(db) as history:
            record = history.installed(vehicle)
        if record is not None:
            where = f"the history ({record.source}, recorded for {vehicle})"
            return profile.resolve_installed(record.pieces, where), where
    return profile.installed, "the profile (ballast.installed)"
