"""``trimd inspect LOG [--profile P] [--json]``: what a vehicle log holds.

Reads a MAVLink ``.tlog`` or an ArduSub DataFlash ``.BIN`` (:func:`trimd.logs.log.open_log`)
and reports its format, duration, vehicle and firmware, frame,
streams and their rates, modes and armed periods, bad frames and sequence gaps, attitude
and depth ranges, and the steady attitude segments (:func:`trimd.core.steady.detect_steady`).
A steady segment is an *attitude hold* when the vehicle was armed (or the log does not
say) in a mode that holds attitude; the report ends by saying whether the log holds any.
Exit 0 for a readable log (holds or not); an unreadable or empty log is a DataError
(exit 2).
"""

from __future__ import annotations

import argparse
import json
import math
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Attitude, Depth, Health, VehicleText
from trimd.core.steady import SteadyCriteria, detect_steady
from trimd.drivers.mavlink.decode import VehicleParams
from trimd.logs.log import open_log

__all__ = ["HOLD_MODES", "format_report", "inspect_log", "register", "run"]

#: ArduSub modes in which the autopilot holds an attitude (a steady segment may be a hold).
HOLD_MODES = frozenset({"STABILIZE", "ALT_HOLD", "AUTO", "GUIDED", "CIRCLE", "POSHOLD",
                        "SURFTRAK"})
#: Steady-state tolerances without a profile (a profile's ``procedure`` overrides them).
DEFAULT_TOL_DEG, DEFAULT_RATE_TOL_DEG_S, DEFAULT_MIN_STEADY_S = 1.0, 1.0, 10.0
#: Attitude resolution of ArduSub logs (DataFlash ATT is in centidegrees) [deg].
LOG_RESOLUTION_DEG = 0.01
#: Vehicle messages the report for people lists (the JSON report has all).
_TEXTS_SHOWN = 12
_SAMPLE_STREAMS = {"ATTITUDE", "SERVO_OUTPUT_RAW", "VFR_HUD", "GLOBAL_POSITION_INT",
                   "SCALED_PRESSURE2", "SYS_STATUS", "BATTERY_STATUS", "HEARTBEAT",
                   "ATT", "RATE", "RCOU", "CTUN", "BARO", "BAT"}


def register(sub: Any) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "inspect", help="report what a vehicle log (.tlog or DataFlash .BIN) holds",
        description="Report a log's format, duration, vehicle, frame, streams and rates, "
        "modes, armed periods, bad frames, attitude range and steady attitude holds.")
    p.add_argument("log", help="a MAVLink .tlog or an ArduSub DataFlash .BIN")
    p.add_argument("--profile", help="vehicle profile (thruster channels, tolerances)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


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


def _state_at(health: list[Health], t_s: float) -> Health | None:
    times = [h.t_s for h in health]
    i = int(np.searchsorted(times, t_s, side="right")) - 1
    return health[i] if i >= 0 else None


def _steady(att: list[Attitude], health: list[Health], profile: Profile | None,
            armed_known: bool) -> list[dict[str, Any]]:
    if len(att) < 3:
        return []
    proc = profile.procedure if profile else None
    tol = math.radians(proc.attitude_tol_deg if proc else DEFAULT_TOL_DEG)
    rate_tol = math.radians(proc.rate_tol_deg_s if proc else DEFAULT_RATE_TOL_DEG_S)
    step = math.radians(LOG_RESOLUTION_DEG)
    criteria = SteadyCriteria(min_duration_s=proc.min_steady_s if proc else
                              DEFAULT_MIN_STEADY_S, drift_tol=(tol, tol),
                              resolution=(step, step))
    t = np.array([a.t_s for a in att])
    angles = np.array([[a.phi, a.theta] for a in att])
    _, segments = detect_steady(t, angles, criteria, rates_rad_s=np.array(
        [[a.p, a.q, a.r] for a in att]), rate_tol_rad_s=rate_tol)
    out = []
    for seg in segments:
        state = _state_at(health, seg.t_start_s)
        mean = np.degrees(angles[seg.start:seg.stop].mean(axis=0))
        out.append({"start_s": seg.t_start_s, "end_s": seg.t_end_s,
                    "roll_deg": float(mean[0]), "pitch_deg": float(mean[1]),
                    "mode": state.mode if state else None,
                    "armed": state.armed if state and armed_known else None,
                    "hold": bool(state and (state.armed or not armed_known)
                                 and state.mode in HOLD_MODES)})
    return out


def inspect_log(path: str | Path, profile: Profile | None = None) -> dict[str, Any]:
    """The report of one log as a JSON-ready dict (times [s] from the log's start)."""
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
        "steady": _steady(att, health, profile, info.pop("armed_known")),
    })
    info["holds"] = sum(s["hold"] for s in info["steady"])
    return info


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
    for s in r["steady"]:
        lines.append(f"steady {s['start_s']:.1f}–{s['end_s']:.1f} s: roll {s['roll_deg']:.2f}°, "
                     f"pitch {s['pitch_deg']:.2f}° in {s['mode'] or '?'}, "
                     f"{ {True: 'armed', False: 'disarmed', None: 'armed?'}[s['armed']]}"
                     f"{' — attitude hold' if s['hold'] else ''}")
    lines.append(f"{r['holds']} steady attitude hold(s) found." if r["holds"] else
                 "No steady attitude holds in this log (nothing to estimate from).")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile) if args.profile else None
    report = inspect_log(args.log, profile)
    print(json.dumps(report) if args.json else format_report(report))
    return 0
