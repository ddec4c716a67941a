"""The options every command that reads or writes the trim history shares: ``--db`` and
``--vehicle``, and the vehicle key they name (docs/operator.md, "The trim history")."""

from __future__ import annotations

import argparse
import re

from trimd.app.history import default_db_path, vehicle_key

__all__ = ["add_db_arg", "add_history_args", "db_path", "vehicle_of"]


def add_db_arg(p: argparse.ArgumentParser) -> None:
    """Add ``--db PATH``."""
    p.add_argument("--db", metavar="PATH", help="the trim history (default: "
                   "$TRIMD_DATA_DIR/trimd.db, else ~/.local/share/trimd/trimd.db)")


def add_history_args(p: argparse.ArgumentParser) -> None:
    """Add ``--db PATH`` and ``--vehicle NAME``."""
    add_db_arg(p)
    p.add_argument("--vehicle", metavar="NAME", help="the vehicle's records in the history "
                   "(default: the profile's name, with #SYSID when a MAVLink system id is "
                   "given)")


def db_path(args: argparse.Namespace) -> str:
    """The history file ``--db`` names, else the default."""
    return str(args.db) if getattr(args, "db", None) else str(default_db_path())


def vehicle_of(args: argparse.Namespace, profile_name: str) -> str:
    """The vehicle key: ``--vehicle``, else the profile's name and the MAVLink system id of
    ``--sysid`` or the link URL's ``sysid=N``, else the profile's name."""
    sysid = getattr(args, "sysid", None)
    link = str(getattr(args, "link", "") or "")
    found = re.search(r"[?&]sysid=(\d+)", link) if link.startswith("mavlink:") else None
    if sysid is None and found:
        sysid = int(found.group(1))
    return vehicle_key(profile_name, sysid, getattr(args, "vehicle", None))
