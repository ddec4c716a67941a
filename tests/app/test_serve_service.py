"""``trimd serve``'s service and routes in process: dives follow the vehicle's arming and
heartbeat, a dive's recording replays to the live watch's segments and alerts exactly, and
the JSON routes answer from the history (a trim's report included) and refuse bad
requests with a JSON error."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

from aiohttp.test_utils import TestClient, TestServer

from tests.helpers import REPO
from trimd.app.history import History
from trimd.app.serve import Service
from trimd.app.watch import watch_log
from trimd.app.web import make_app
from trimd.core.profile_yaml import load_profile, read_profile_text
from trimd.core.samples import Health, ModeClass
from trimd.core.watch import TrimWatch

GOLDEN = REPO / "tests" / "data" / "golden" / "sabertooth-10kg-aftsb.expected.json"
PROFILE = "sabertooth-dh2"


class Quiet:
    """A link that is never read: the service is fed samples by the test."""

    description = "a test link"


def _service(tmp_path: Path, history: History, url: str = "mavlink:udpin:127.0.0.1:1",
             profile_name: str = PROFILE) -> Service:
    profile = load_profile(profile_name)
    return Service(url, profile, read_profile_text(profile_name)[0], tmp_path, history,
                   profile_name, lambda clock: TrimWatch(profile, clock=clock), rate=None,
                   log=lambda line: None)


def _health(t_s: float, connected: bool, armed: bool) -> Health:
    return Health(t_s, connected, "ALT_HOLD", armed, mode_class=ModeClass.DEPTH_HOLDING)


def test_a_dive_is_armed_with_the_heartbeat_coming(tmp_path: Path) -> None:
    with History(tmp_path / "trimd.db") as history:
        service = _service(tmp_path, history)
        link: Any = Quiet()
        service.sample(link, _health(10.0, True, False))
        assert service.dive is None
        for t, connected, armed in [(11.0, True, True), (15.0, True, True), (20.0, True, False),
                                    (21.0, True, True), (30.0, False, False)]:
            service.sample(link, _health(t, connected, armed))
        assert service.dive is None and len(service.past) == 2
        first, second = service.past
        assert first.id != second.id and first.duration_s == 4.0
        assert all(d.recording.stat().st_size > 0 for d in service.past)


async def _dive(service: Service, dive_s: float) -> None:
    """Run ``service`` until its dive is ``dive_s`` long [s of dive time], then stop it
    (which ends the dive)."""
    stop = asyncio.Event()

    async def stopper() -> None:
        while service.dive is None or service.dive.duration_s < dive_s:
            await asyncio.sleep(0.05)
        stop.set()

    await asyncio.gather(service.run(stop), stopper())


def test_a_dives_recording_replays_to_the_live_segments(tmp_path: Path) -> None:
    """The simulated Heavy's scripted dive watched live, then its recording: the same
    segments, to the sample and the bit. (Before the watch saw its samples' times as the
    recording stores them, to the µs, the first segment began a sample earlier live: a
    dive time off by 1e-14 s.)"""
    profile = load_profile("bluerov2-heavy")
    with History(tmp_path / "trimd.db") as history:
        service = _service(tmp_path, history, "sim:pilot=dive", "bluerov2-heavy")
        asyncio.run(_dive(service, 100.0))
    dive = service.past[0]
    live = [s.to_dict() for s in dive.watch.watch.segments]
    replayed: list[dict[str, Any]] = []
    watch_log(str(dive.recording), profile, TrimWatch(profile),
              lambda r: replayed.append(r.to_dict()))
    assert len(live) >= 2
    assert replayed == live


async def _get(service: Service, path: str) -> tuple[int, Any]:
    async with TestClient(TestServer(make_app(service))) as client:
        r = await client.get(path)
        return r.status, json.loads(await r.text())


def test_the_routes_answer_from_the_history(tmp_path: Path) -> None:
    golden = json.loads(GOLDEN.read_text(encoding="utf-8"))
    with History(tmp_path / "trimd.db") as history:
        history.record_trim(PROFILE, PROFILE, 1000.0, golden["estimate"], golden["proposal"])
        history.record_verify(PROFILE, 2000.0, {"message": "level, as predicted"})
        history.record_alert(PROFILE, 3000.0, {"type": "alert", "text": "heavier", "dive": "D"})
        service = _service(tmp_path, history)

        def get(path: str) -> tuple[int, Any]:
            return asyncio.run(_get(service, path))

        code, report = get("/api/trims/-1/report")
        assert code == 200 and "extra mass m_ext" in report["estimate_text"]
        assert report["proposal"]["method"] == golden["proposal"]["method"]
        assert [v["message"] for v in report["verifications"]] == ["level, as predicted"]
        code, status = get("/api/status")
        assert code == 200 and not status["connected"] and status["alerts"] == 1
        assert get("/api/segments")[1]["alerts"][0]["text"] == "heavier"
        assert [d["id"] for d in get("/api/dives")[1]["dives"]] == ["D"]
        for path, want in [("/api/trims/1/report", 404), ("/api/trims/x/report", 400),
                           ("/api/segments?dive=nope", 404)]:
            code, body = get(path)
            assert code == want and body["error"], (path, body)


def test_a_dive_the_disk_refuses_is_watched_unrecorded(tmp_path: Path) -> None:
    (tmp_path / "dives").write_text("not a folder")
    lines: list[str] = []
    with History(tmp_path / "trimd.db") as history:
        service = _service(tmp_path, history)
        service._log = lines.append
        link: Any = Quiet()
        for t, armed in [(1.0, True), (2.0, True), (3.0, False)]:
            service.sample(link, _health(t, True, armed))
    assert len(service.past) == 1 and service.past[0].duration_s == 1.0
    assert any("not recorded" in line for line in lines), lines
