"""``trimd replay`` in the TUI (Textual's pilot): a recording of a live session on the
in-process simulator, paused, at other speeds, ends with the live estimate and proposal."""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path
from typing import Any

import pytest

from tests.tui.tui_helpers import until
from trimd.ballast.propose import proposal_to_dict
from trimd.cli.main import main
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.events import Phase
from trimd.core.profile import Profile
from trimd.tui.link_panel import LinkPanel
from trimd.tui.replay_app import replay_app
from trimd.tui.replay_pace import SPEEDS
from trimd.tui.result_panel import ResultPanel


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    """A live session on the simulator, recorded, and its JSON result line."""
    log = tmp_path_factory.mktemp("replay") / "live.tlog"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["run", "--link", "sim:payload=10@AftSB,seed=2", "--profile",
                     "sabertooth-dh2", "--headless", "--yes", "--json",
                     "--record", str(log)]) == 0
    live: dict[str, Any] = json.loads(out.getvalue().splitlines()[-1])
    assert live["type"] == "result"
    return log, live


def _json(obj: object) -> object:
    return json.loads(json.dumps(obj))


@pytest.mark.asyncio
async def test_replay_pauses_changes_speed_and_gives_the_live_result(
        recording: tuple[Path, dict[str, Any]], sabertooth: Profile) -> None:
    log, live = recording
    app = replay_app(str(log), sabertooth, speed=1.0, method="milp")
    pace = app.replay
    assert pace is not None
    async with app.run_test(size=(80, 24)) as pilot:
        subtitle = app.query_one(LinkPanel)
        await until(pilot, lambda: pace.t_s > 1.0)  # at real time
        assert subtitle.border_subtitle == "replay 1×"
        await pilot.press("space")
        assert pace.paused and subtitle.border_subtitle == "replay paused"
        held = pace.t_s
        await pilot.pause(0.5)  # wall time passes, the recording does not
        assert pace.t_s == held and app.result is None
        await pilot.press("plus")
        assert pace.speed == 2.0
        await pilot.press("minus", "minus")
        assert pace.speed == 0.5
        for _ in SPEEDS:
            await pilot.press("plus")
        assert math.isinf(pace.speed) and pace.paused  # the speed alone does not resume
        await pilot.press("space")
        assert subtitle.border_subtitle == "replay fast"
        await until(pilot, lambda: app.result is not None)
        result = app.result
        assert result is not None and result.phase is Phase.DONE, result
        assert app.query_one(ResultPanel).estimate is result.estimate
    assert _json(estimate_to_dict(result.estimate)) == live["estimate"]
    assert _json(proposal_to_dict(result.proposal)) == live["proposal"]
    assert not pace.link.warnings
