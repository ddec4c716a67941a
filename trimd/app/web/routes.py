"""The routes of ``trimd serve`` (docs/operator.md, "serve"): JSON for programs, a page
for people, and BlueOS's ``/register_service``.

Every answer is JSON (``application/json``) but ``/`` and ``/static/…``. Times are s
since the Unix epoch (``t_unix``) with UTC text beside them; forces in N, moments in N·m,
as the keys say. A request trimd cannot answer (an unknown dive, a trim index out of
range, a malformed number) gets 400 or 404 with ``{"error": text}``, never a traceback.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

from aiohttp import web

from trimd import __version__
from trimd.app.history.report import history_to_dict, utc_text
from trimd.app.history.store import EventRecord
from trimd.app.report import format_estimate
from trimd.app.serve import Dive, Service
from trimd.core.errors import DataError
from trimd.core.estimate_json import estimate_from_dict

__all__ = ["API_PATHS", "make_app"]

STATIC = Path(__file__).parent / "static"
SERVICE = web.AppKey("service", Service)
#: The JSON routes, for people and the docs: path → what it answers.
API_PATHS = {
    "/api/status": "the link, the vehicle's mode and arming, the current dive",
    "/api/dives": "every dive in the history and its recording",
    "/api/segments?dive=ID": "a dive's segments and alerts (default: the current or last "
                             "dive) and, while it runs, its baseline",
    "/api/alerts": "every watch alert of the vehicle",
    "/api/history": "the trim history (trimd history --json)",
    "/api/trims/{n}/report": "trim n (0 the first, -1 the last): its estimate as text, "
                             "its proposal and the verify holds after it",
    "/register_service": "what BlueOS lists in its menu",
}


def _error(status: type[web.HTTPException], text: str) -> web.HTTPException:
    return status(text=json.dumps({"error": text}), content_type="application/json")


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _dive_dict(d: Dive) -> dict[str, Any]:
    w = d.watch.watch
    return {"id": d.id, "started_unix": d.started_unix, "started_utc": utc_text(d.started_unix),
            "ended_unix": d.ended_unix, "duration_s": d.duration_s,
            "recording": str(d.recording),
            "segments": len(w.segments), "alerts": len(w.alerts)}


def _baseline(d: Dive) -> dict[str, Any] | None:
    """The running dive's baseline: W − B and the x/y net moments and their 1σ."""
    detector = d.watch.watch.detector
    if detector is None:
        return None
    b = detector.baseline
    return {"q": [_finite(b.q[i]) for i in range(3)],
            "std": [_finite(math.sqrt(b.var[i])) for i in range(3)], "source": b.source}


def _event(r: EventRecord) -> dict[str, Any]:
    return {"t_unix": r.t_unix, "time_utc": utc_text(r.t_unix), **r.values}


async def status(request: web.Request) -> web.Response:
    s = request.app[SERVICE]
    h = s.health
    return web.json_response({
        "version": __version__, "vehicle": s.vehicle, "profile": s.profile.name,
        "link": s.url, "link_description": s.link_description, "link_error": s.link_error,
        "connected": bool(h and h.connected), "armed": bool(h and h.armed),
        "mode": h.mode if h else "", "vehicle_reports": h.vehicle if h else "",
        "started_unix": s.started_unix, "uptime_s": time.time() - s.started_unix,
        "dive": None if s.dive is None else _dive_dict(s.dive),
        "dives_since_start": len(s.past), "alerts": len(s.history.alerts(s.vehicle)),
        "store_errors": s.store_errors, "data": str(s.data), "db": str(s.history.path),
        "passive": True, "trims": "started from the topside: trimd run"})


def _dive_ids(s: Service) -> list[str]:
    """Every dive with a record in the history, and the running one, oldest first."""
    ids = set(s.history.dives(s.vehicle))
    if s.dive is not None:
        ids.add(s.dive.id)
    return sorted(ids)


async def dives(request: web.Request) -> web.Response:
    s = request.app[SERVICE]
    known = {d.id: d for d in [*s.past, *([s.dive] if s.dive else [])]}
    recordings = {p.name.split("-", 1)[0]: str(p) for p in (s.data / "dives").glob("*.tlog")}
    out: list[dict[str, Any]] = []
    for ident in sorted(set(_dive_ids(s)) | set(recordings)):
        d = known.get(ident)
        out.append({**(_dive_dict(d) if d is not None else
                       {"id": ident, "recording": recordings.get(ident)}),
                    "running": s.dive is not None and ident == s.dive.id})
    return web.json_response({"dives": out})


async def segments(request: web.Request) -> web.Response:
    s = request.app[SERVICE]
    ids = _dive_ids(s)
    ident = request.query.get("dive") or (ids[-1] if ids else "")
    if ident and ident not in ids:
        raise _error(web.HTTPNotFound, f"no dive {ident!r} (GET /api/dives lists them)")
    pick = [_event(r) for r in s.history.watch_segments(s.vehicle, ident)]
    alerts = [_event(r) for r in s.history.alerts(s.vehicle, ident)]
    running = s.dive is not None and s.dive.id == ident
    return web.json_response({"dive": ident or None, "running": running,
                              "baseline": _baseline(s.dive) if running and s.dive else None,
                              "segments": pick, "alerts": alerts})


async def alerts(request: web.Request) -> web.Response:
    s = request.app[SERVICE]
    return web.json_response({"vehicle": s.vehicle,
                              "alerts": [_event(r) for r in s.history.alerts(s.vehicle)]})


async def history(request: web.Request) -> web.Response:
    s = request.app[SERVICE]
    return web.json_response(history_to_dict(s.history, s.history.vehicles()))


async def trim_report(request: web.Request) -> web.Response:
    s = request.app[SERVICE]
    trims = s.history.trims(s.vehicle)
    try:
        n = int(request.match_info["n"])
        trim = trims[n]
    except ValueError:
        raise _error(web.HTTPBadRequest, f"trim index {request.match_info['n']!r}: not an "
                     "integer (0 the first trim, -1 the last)") from None
    except IndexError:
        raise _error(web.HTTPNotFound, f"no trim {n}: the history holds {len(trims)} trim(s) "
                     f"of {s.vehicle}") from None
    try:
        text = format_estimate(estimate_from_dict(trim.estimate, str(s.history.path)))
    except DataError as exc:
        text = f"the stored estimate cannot be read: {exc}"
    verifies = [_event(r) for r in s.history.verifications(s.vehicle) if r.t_unix >= trim.t_unix]
    return web.json_response({"index": trims.index(trim), "t_unix": trim.t_unix,
                              "time_utc": utc_text(trim.t_unix), "profile": trim.profile,
                              "estimate_text": text, "estimate": trim.estimate,
                              "proposal": trim.proposal, "log_path": trim.log_path,
                              "verifications": verifies})


async def register_service(request: web.Request) -> web.Response:
    """What BlueOS's helper asks each port for to list a service in its menu."""
    return web.json_response({
        "name": "trimd", "description": "Trim watch: the vehicle's W − B and moments on every "
        "dive, alerts (water ingress?), the trim history", "icon": "mdi-scale-balance",
        "company": "trimd", "version": __version__, "webpage": "/", "api": "/api/status",
        "new_page": False, "works_in_relative_paths": True})


async def index(request: web.Request) -> web.FileResponse:
    return web.FileResponse(STATIC / "index.html")


def make_app(service: Service) -> web.Application:
    """The aiohttp application serving ``service``'s state."""
    app = web.Application()
    app[SERVICE] = service
    app.router.add_get("/", index)
    app.router.add_get("/api/status", status)
    app.router.add_get("/api/dives", dives)
    app.router.add_get("/api/segments", segments)
    app.router.add_get("/api/alerts", alerts)
    app.router.add_get("/api/history", history)
    app.router.add_get("/api/trims/{n}/report", trim_report)
    app.router.add_get("/register_service", register_service)
    app.router.add_static("/static", STATIC)
    return app
