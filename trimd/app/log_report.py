"""What a vehicle log holds: the report of ``trimd inspect`` (and of ``trimd replay`` of a
foreign log).

Reads a MAVLink ``.tlog`` or an ArduSub DataFlash ``.BIN`` (:func:`trimd.logs.log.open_log`)
and reports its format, duration, vehicle and firmware, frame, streams and their rates,
modes and armed periods, bad frames and sequence gaps, attitude and depth ranges, and, with
a profile, the steady attitude holds (:func:`trimd.app.logholds.log_holds`: the live
settling test over the log's attitude plateaus, the holds ``trimd replay`` estimates
from); the report ends by saying whether the log holds any, or why not. Without a profile
no hold is looked for: the settling test reads the thrusters' effort, which needs the
profile's thrusters. An unreadable or empty log is a DataError.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import Any

from trimd.app.jsonlines import print_result
from trimd.app.logholds import format_hold, hold_to_dict, log_holds
from trimd.core.errors import DataError
from trimd.core.holdfinder import FoundHold
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Depth, Health, Sample, VehicleText
from trimd.drivers.mavlink.decode import VehicleParams
from trimd.logs.log import open_log

__all__ = ["NO_PROFILE", "format_report", "inspect_log", "log_report", "print_report"]

#: Why a report without a profile lists no holds.
NO_PROFILE = ("not looked for without --profile (the settling test reads the thrusters' "
              "effort, which needs the profile's thrusters)")
#: Vehicle messages the report for people lists (the JSON report has all).
_TEXTS_SHOWN = 12
_SAMPLE_STREAMS = {"ATTITUDE", "SERVO_OUTPUT_RAW", "VFR_HUD", "GLOBAL_POSITION_INT",
                   "SCALED_PRESSURE2", "SYS_STATUS", "BATTERY_STATUS", "HEARTBEAT",
                   "ATT", "RATE", "RCOU", "CTUN", "BARO", "BAT"}


def _periods(health: list[Health], end_s: float) -> tuple[list[dict[str, Any]], list[list[float]]]:
    """Mode periods and armed periods [s] from the Health samples."""
    modes: list[dict[str, Any]] = []
    armed: list[list[float]] = []
    for i, h in enumerate(health):
        until = health[i + 1].t_s if i + 1 < len(health) else end_s
        if modes and modes[-1]["mode"] == h.mode:
            modes[-1]["end_s"] = until
        else:
            modes.append({"mode": h.mode, "start_s": h.t_s, "end_s": until})
        if h.armed and armed and armed[-1][1] == h.t_s:
            armed[-1][1] = until
        elif h.armed:
            armed.append([h.t_s, until])
    return modes, armed


def _holds(samples: list[Sample], profile: Profile | None) -> tuple[list[FoundHold], str]:
    """The log's steady holds and, when there is none, why."""
    if profile is None:
        return [], NO_PROFILE
    try:
        return log_holds(samples, profile), ""
    except DataError as exc:
        return [], str(exc)


def inspect_log(path: str | Path, profile: Profile | None = None) -> dict[str, Any]:
    """The report of one log as a JSON-ready dict (times [s] from the log's start)."""
    return log_report(path, profile)[0]


def log_report(path: str | Path, profile: Profile | None = None
               ) -> tuple[dict[str, Any], list[FoundHold]]:
    """:func:`inspect_log` and the holds it lists (none without a profile)."""
    p = Path(path)
    log = open_log(p, profile)
    samples = list(log.samples())
    info = log.summary()
    duration = info["duration_s"]
    att = [s for s in samples if isinstance(s, Attitude)]
    depth = [s.depth_m for s in samples if isinstance(s, Depth)]
    health = [s for s in samples if isinstance(s, Health)]
    texts = [{"t_s": s.t_s, "severity": s.severity, "level": s.level, "text": s.text}
             for s in samples if isinstance(s, VehicleText)]
    params: VehicleParams = info.pop("params")
    counts: Counter[str] = info.pop("counts")
    modes, armed = _periods(health, duration)
    info.update({
        "file": str(p), "frame_config": params.frame_config,
        "profile_disagreements": params.disagreements(profile) if profile else [],
        "streams": {k: {"count": n, "rate_hz": n / duration if duration > 0 else None}
                    for k, n in counts.most_common()},
        "samples": dict(Counter(type(s).__name__ for s in samples)),
        "modes": modes, "armed_periods": armed if info["armed_known"] else None,
        "vehicle_messages": texts,
        "roll_deg": _range([math.degrees(a.phi) for a in att]),
        "pitch_deg": _range([math.degrees(a.theta) for a in att]),
        "depth_m": _range(depth),
    })
    info.pop("armed_known")
    found, why = _holds(samples, profile)
    info["holds"] = None if profile is None else [hold_to_dict(h) for h in found]
    info["no_holds_because"] = why or None
    return info, found


def _range(values: list[float]) -> list[float] | None:
    return [min(values), max(values)] if values else None


def _fmt_range(r: list[float] | None, unit: str) -> str:
    return "none" if r is None else f"{r[0]:.2f} … {r[1]:.2f} {unit}"


def format_report(r: dict[str, Any]) -> str:
    """The report for people."""
    lines = [f"{r['file']}: {r['format']}, {r['duration_s']:.1f} s (starts at {r['start']}), "
             f"{r['messages']} records",
             f"vehicle: {r['firmware'] or 'firmware not logged'}"
             + (f", {r['vehicle']}" if r["vehicle"] else "")
             + f"; FRAME_CONFIG {r['frame_config'] if r['frame_config'] is not None else '?'}"]
    lines += [f"  warning: {d}" for d in r["profile_disagreements"]]
    streams = r["streams"]
    shown = [f"{k} {v['rate_hz']:.1f} Hz" for k, v in streams.items()
             if k in _SAMPLE_STREAMS and v["rate_hz"] is not None]
    lines.append(f"streams: {', '.join(shown) or 'none with samples'}"
                 f" (+{len(streams) - len(shown)} other types)")
    lines.append("samples: " + ", ".join(f"{k} {n}" for k, n in r["samples"].items())
                 + ("; rejected " + ", ".join(f"{k} {n}" for k, n in r["rejected"].items())
                    if r["rejected"] else ""))
    lines.append("modes: " + (", ".join(f"{m['mode']} {m['start_s']:.1f}–{m['end_s']:.1f} s"
                                        for m in r["modes"]) or "not logged"))
    armed = r["armed_periods"]
    lines.append("armed: " + ("not logged" if armed is None else ", ".join(
        f"{a:.1f}–{b:.1f} s" for a, b in armed) or "never"))
    if "bad_crc" in r:
        gaps = ", ".join(f"{k} {n}" for k, n in r["sequence_gaps"].items()) or "none"
        first = (f", the first bad frame at byte {r['first_skip_at']}"
                 if r["first_skip_at"] is not None else "")
        lines.append(f"bad frames: {r['bad_frames']} ({r['bad_crc']} bad CRC, "
                     f"{r['skipped_bytes']} bytes skipped{first}); sequence gaps "
                     f"(sys/comp): {gaps}")
    elif r["skipped_bytes"]:
        lines.append(f"warning: {r['skipped_bytes']} damaged bytes skipped (the first at byte "
                     f"{r['first_skip_at']})")
    if r["truncated_at"] is not None:
        lines.append(f"warning: the last record is truncated at byte {r['truncated_at']}")
    if r.get("error"):
        lines.append(f"warning: {r['error']}")
    texts = r["vehicle_messages"]
    if texts:
        more = len(texts) - _TEXTS_SHOWN
        lines.append(f"vehicle messages: {len(texts)}"
                     + (f" (the first {_TEXTS_SHOWN}; --json lists all)" if more > 0 else ""))
        lines += [f"  {m['t_s']:7.1f} s {m['level']}: {m['text']}"
                  for m in texts[:_TEXTS_SHOWN]]
    lines.append(f"attitude: roll {_fmt_range(r['roll_deg'], '°')}, "
                 f"pitch {_fmt_range(r['pitch_deg'], '°')}; depth {_fmt_range(r['depth_m'], 'm')}")
    holds = r["holds"] or []
    lines += [format_hold(h) for h in holds]
    lines.append(f"{len(holds)} steady attitude hold(s) found." if holds else
                 f"No steady attitude holds in this log: {r['no_holds_because']}.")
    return "\n".join(lines)


def print_report(report: dict[str, Any], as_json: bool) -> None:
    """The report on stdout: a ``log`` JSON line, or the text for people."""
    print_result(as_json, {"type": "log", **report}, format_report(report))
