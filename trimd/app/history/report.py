"""``trimd history``'s text and JSON: a vehicle's trims, installed ballast, watch alerts,
verify holds with their corrections, and the thrust map's calibration (each experiment,
and the gains as the latest one left them, :mod:`trimd.app.history.calibration`). Times
are UTC; lengths in millimetres; ± is one standard deviation."""

from __future__ import annotations

import datetime as dt
import math
from typing import Any

from trimd.app.history.store import (
    CorrectionRecord,
    EventRecord,
    History,
    InstallRecord,
    TrimRecord,
)

__all__ = ["format_history", "history_to_dict", "utc_text"]


def utc_text(t_unix: float) -> str:
    """``YYYY-mm-dd HH:MM:SS UTC``."""
    return dt.datetime.fromtimestamp(t_unix, dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")


def _trim_line(r: TrimRecord) -> str:
    e = r.estimate
    cov = e.get("cov_net") or [[math.nan]]
    cg = [1e3 * v for v in e.get("cg_m", [math.nan] * 3)]
    cg_std = [1e3 * v for v in e.get("cg_std_m", [math.nan] * 3)]
    text = (f"  {utc_text(r.t_unix)}  W − B {e.get('net_force_N', math.nan):+.2f} ± "
            f"{math.sqrt(max(cov[0][0], 0.0)):.2f} N  CG "
            + " ".join(f"{a} {v:+.1f} ± {s:.1f}" for a, v, s in zip("xyz", cg, cg_std,
                                                                     strict=True)) + " mm")
    if r.proposal is not None:
        text += "\n      " + _proposal_text("proposal", r.proposal)
    if r.log_path:
        text += f"\n      session log {r.log_path}"
    return text


def _proposal_text(what: str, p: dict[str, Any]) -> str:
    """``proposal milp: 3 piece(s) to handle, feasible``."""
    changes = p.get("changes") or [{"action": "add", "piece": n, "count": c}
                                   for s in p.get("slots", [])
                                   for n, c in s.get("pieces", {}).items()]
    pieces = sum(int(c["count"]) for c in changes)
    return (f"{what} {p.get('method')}: {pieces} piece(s) "
            f"{'to handle' if p.get('changes') else 'to add'}, "
            f"{'feasible' if p.get('feasible') else 'NOT feasible'}")


def _correction_text(r: CorrectionRecord) -> str:
    """The correction under its verify hold or float check: its pieces and the changes,
    in words."""
    changes = "; ".join(str(c.get("text")) for c in r.proposal.get("changes", []))
    return "      " + _proposal_text("correction", r.proposal) + (f" ({changes})" if changes
                                                                else "")


def _install_text(r: InstallRecord) -> str:
    pieces = "; ".join(f"{p.slot}: {p.count} × {p.piece}" for p in r.pieces) or "none"
    return f"  {utc_text(r.t_unix)}  ({r.source})  {pieces}"


def _event_text(r: EventRecord) -> str:
    """An alert's ``text`` or a verify hold's ``message``, else its values."""
    text = r.values.get("text") or r.values.get("message")
    body = str(text) if text else ", ".join(f"{k} {v}" for k, v in sorted(r.values.items()))
    return f"  {utc_text(r.t_unix)}  {body}"


def _calibration_dict(history: History, vehicle: str) -> dict[str, Any]:
    """The vehicle's calibration experiments and the gains and dead-band edges the latest
    one left, those the data determine (experiments stored before band edges were: none)."""
    records = history.experiments(vehicle)
    latest = records[-1].values.get("calibration", {}) if records else {}
    return {"learnt": int(latest.get("experiments", 0)),
            "rejected": sum(1 for r in records if not r.values.get("accepted")),
            "gains": [g for g in latest.get("gains", []) if g.get("determined")],
            "band_edges": [b for b in latest.get("band_edges", []) if b.get("determined")],
            "experiments": [{"id": r.id, **{k: x for k, x in _event_dict(r).items()
                                            if k not in ("experiment", "calibration")}}
                            for r in records]}


def _calibration_lines(history: History, vehicle: str) -> list[str]:
    c = _calibration_dict(history, vehicle)
    if not c["experiments"]:
        return ["thrust map calibration: no experiment"]
    lines = [f"thrust map calibration: {c['learnt']} experiment(s) learnt, {c['rejected']} "
             "rejected; the gains the data determine (true thrust = (1 + gain)·curve):"]
    lines += [f"  {g['thruster']} {g['direction']}: {g['mean_pct']:+.1f} ± "
              f"{g['std_pct']:.1f} % (prior ± {g['prior_std_pct']:.1f} %)" for g in c["gains"]]
    if not c["gains"]:
        lines.append("  none yet narrowed below 90 % of its prior σ")
    if c["band_edges"]:
        lines.append("  and the ESC dead-band edges (offset from the profile's, later in PWM "
                     "positive):")
        lines += [f"  {b['thruster']} band {b['edge']} edge: {b['mean_us']:+.1f} ± "
                  f"{b['std_us']:.1f} µs (prior ± {b['prior_std_us']:.1f} µs)"
                  for b in c["band_edges"]]
    lines += [f"  {e['time_utc']}  {e['message']}" for e in c["experiments"]
              if not e["accepted"]]
    return lines


def format_history(history: History, vehicles: list[str]) -> str:
    """The records of ``vehicles``, oldest first, each kind under its heading."""
    blocks = []
    for v in vehicles:
        trims, installs = history.trims(v), history.installs(v)
        alerts, verifies = history.alerts(v), history.verifications(v)
        segments = history.watch_segments(v)
        lines = [f"vehicle {v}", f"trims: {len(trims) or 'none'}"]
        lines += [_trim_line(r) for r in trims]
        lines.append("installed ballast: " + ("none recorded" if not installs else
                                              f"{len(installs)} configuration(s), latest last"))
        lines += [_install_text(r) for r in installs]
        lines.append(f"watch: {len(segments)} steady segment(s), {len(alerts)} alert(s)")
        lines += [_event_text(r) for r in alerts]
        corrections = history.corrections(v)
        lines += _with_corrections("verify holds", verifies,
                                   {c.verify_id: c for c in corrections})
        lines += _with_corrections("float checks", history.float_checks(v),
                                   {c.float_id: c for c in corrections})
        lines += _calibration_lines(history, v)
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def _with_corrections(what: str, records: list[EventRecord],
                      corrections: dict[int | None, CorrectionRecord]) -> list[str]:
    """A heading with the count of ``records`` (verify holds, float checks), then each
    with the correction that came from it."""
    lines = [f"{what}: {len(records) or 'none'}"]
    for r in records:
        lines.append(_event_text(r))
        if r.id in corrections:
            lines.append(_correction_text(corrections[r.id]))
    return lines


def _event_dict(r: EventRecord) -> dict[str, Any]:
    return {"t_unix": r.t_unix, "time_utc": utc_text(r.t_unix), **r.values}


def history_to_dict(history: History, vehicles: list[str]) -> dict[str, Any]:
    """JSON-ready: the file's path and, per vehicle, every record (times in s since the
    Unix epoch and as UTC text; estimates and proposals in their ``--json`` shapes)."""
    return {"db": str(history.path), "vehicles": [{
        "vehicle": v,
        "trims": [{"t_unix": r.t_unix, "time_utc": utc_text(r.t_unix), "profile": r.profile,
                   "estimate": r.estimate, "proposal": r.proposal, "log_path": r.log_path}
                  for r in history.trims(v)],
        "installed": [{"t_unix": r.t_unix, "time_utc": utc_text(r.t_unix), "source": r.source,
                       "profile": r.profile, "pieces": [
                           {"slot": p.slot, "piece": p.piece, "count": p.count}
                           for p in r.pieces]} for r in history.installs(v)],
        "watch_segments": [_event_dict(r) for r in history.watch_segments(v)],
        "alerts": [_event_dict(r) for r in history.alerts(v)],
        "verifications": [{"id": r.id, **_event_dict(r)} for r in history.verifications(v)],
        "float_checks": [{"id": r.id, **_event_dict(r)} for r in history.float_checks(v)],
        "corrections": [{"t_unix": r.t_unix, "time_utc": utc_text(r.t_unix),
                         "verify_id": r.verify_id, "float_id": r.float_id,
                         "estimate": r.estimate, "proposal": r.proposal}
                        for r in history.corrections(v)],
        "calibration": _calibration_dict(history, v),
    } for v in vehicles]}
