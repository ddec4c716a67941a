"""The files trimd reads and writes besides its logs: where session logs go, saved estimates
(``trimd solve --json``, a TUI report, ``trimd run --json`` output) and the static terms an
identification is held at."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from trimd.ballast.check import SlotLoad
from trimd.core.errors import DataError
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import estimate_from_dict
from trimd.core.profile import Profile
from trimd.identify.model import Statics, statics_from_estimate

__all__ = ["data_dir", "default_record_path", "installed_from_json", "read_estimate",
           "read_installed", "read_statics"]


def data_dir() -> Path:
    """Where trimd keeps its data: ``$TRIMD_DATA_DIR``, else ``$XDG_DATA_HOME/trimd``, else
    ``~/.local/share/trimd``."""
    base = os.environ.get("TRIMD_DATA_DIR") or os.path.join(
        os.environ.get("XDG_DATA_HOME") or os.path.expanduser("~/.local/share"), "trimd")
    return Path(base)


def default_record_path(profile: Profile) -> Path:
    """``<data dir>/sessions/YYYYmmdd-HHMMSS-<profile>.tlog``."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    return data_dir() / "sessions" / f"{stamp}-{profile.name}.tlog"


def _result_json(text: str, path: str | Path) -> object:
    """The JSON object in ``text``: the file itself, or the last ``result`` line of
    ``trimd run --json`` (or ``correction`` line, of ``trimd run --verify --json``: the
    vehicle as the verify hold measured it and the correction's proposal)."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        lines = []
        for line in filter(str.strip, text.splitlines()):
            try:
                lines.append(json.loads(line))
            except json.JSONDecodeError:
                raise DataError(f"{path}: not valid JSON ({exc})") from None
        results = [x for x in lines if isinstance(x, dict) and (x.get("type") == "result" or (
            x.get("type") == "correction" and x.get("proposal")))]
        if not results:
            raise DataError(f"{path}: no result line (trimd run --json)") from None
        data = results[-1]
    if isinstance(data, dict) and data.get("type") == "error":
        raise DataError(f"{path}: holds the error of the command that wrote it: "
                        f"{data.get('message')}")
    return data


def _estimate_json(text: str, path: str | Path) -> object:
    """The estimate's JSON object in ``text``: the file itself (``trimd solve --json``),
    its ``estimate`` member (``trimd run``'s report), or that of the last ``result`` line
    of ``trimd run --json``."""
    data = _result_json(text, path)
    if isinstance(data, dict) and "weight_N" not in data and "estimate" in data:
        if data["estimate"] is None:
            raise DataError(f"{path}: that session produced no estimate")
        return data["estimate"]
    return data


def _read_text(path: str | Path, what: str) -> str:
    """The text of the file at ``path``; DataError naming it and ``what`` it should hold
    when it cannot be read or is not UTF-8 text."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise DataError(f"{path}: cannot read {what} ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a text file ({what} expected, as JSON)") from None


def read_estimate(path: str | Path) -> StaticEstimate:
    """The estimate in ``path`` (any form :func:`_estimate_json` takes); DataError naming
    the file for anything unusable."""
    text = _read_text(path, "estimate")
    try:
        return estimate_from_dict(_estimate_json(text, path), str(path))
    except DataError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise DataError(f"{path}: malformed estimate ({type(exc).__name__}: {exc}); expected "
                        "the output of trimd solve --json") from None


def read_installed(path: str | Path, profile: Profile) -> list[SlotLoad]:
    """The ballast a trim proposed, as installed: the ``proposal`` of ``trimd run``'s
    report or of the last ``result`` line of ``trimd run --json`` in ``path``. DataError
    naming the file when it holds no proposal or one for slots ``profile`` lacks."""
    return installed_from_json(_read_text(path, "the trim"), path, profile)


def installed_from_json(text: str, path: str | Path, profile: Profile) -> list[SlotLoad]:
    """:func:`read_installed` of a file's ``text`` (``path`` names it in errors)."""
    data = _result_json(text, path)
    proposal = data.get("proposal") if isinstance(data, dict) else None
    if not isinstance(proposal, dict):
        raise DataError(f"{path}: no ballast proposal in it: give the output of the trim "
                        "whose ballast was installed (trimd run --json, or its report)")
    g, slots = profile.gravity_m_s2, {s.name for s in profile.slots}
    try:
        loads = [SlotLoad(s["name"], tuple(map(float, s["position_m"])),  # type: ignore[arg-type]
                          float(s["weight_kg"]), float(s["float_kg"]), float(s["mass_kg"]),
                          float(s["mass_kg"]) * g - float(s["net_down_N"]),
                          float(s["net_down_N"]),
                          tuple((str(k), int(n)) for k, n in s["pieces"].items()),
                          tuple((str(k), int(n)) for k, n in s.get("removed", {}).items()))
                 for s in proposal["slots"]]
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise DataError(f"{path}: malformed proposal ({type(exc).__name__}: {exc})") from None
    unknown = sorted({ld.name for ld in loads} - slots)
    if unknown:
        raise DataError(f"{path}: the proposal uses slots {unknown} that profile "
                        f"'{profile.name}' does not have: wrong profile?")
    return loads


def read_statics(path: str) -> Statics:
    """Mass and restoring terms from a static estimate file (any form
    :func:`trimd.cli.ballast.read_estimate` takes); DataError naming the file for anything
    unusable."""
    return statics_from_estimate(read_estimate(path), f"estimate {Path(path).name}")
