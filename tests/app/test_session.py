"""The session: procedure + link + recorder + presenters, with a fake in-process link."""

from __future__ import annotations

import asyncio
import io
import json
from typing import Any, ClassVar

import numpy as np
import pytest

from tests.helpers import FakeLink, FakeVehicle, payload_truth
from trimd.app.headless import HeadlessPresenter
from trimd.app.session import Session
from trimd.core.events import Notice, Output, Phase, Progress
from trimd.core.profile import Profile
from trimd.core.samples import Command, HoldAttitude, PilotInput, Release, Sample


class ListRecorder:
    path = "memory"

    def __init__(self) -> None:
        self.samples: list[Sample] = []
        self.commands: list[tuple[float, Command]] = []
        self.notices: list[Notice] = []
        self.closed = False

    def sample(self, sample: Sample) -> Sample:
        self.samples.append(sample)
        return sample

    def raw(self, t_s: float, packet: bytes) -> None:
        raise AssertionError("a fake link has no raw packets")

    def command(self, t_s: float, command: Command) -> None:
        self.commands.append((t_s, command))

    def notice(self, notice: Notice) -> None:
        self.notices.append(notice)

    def flush_due(self) -> None:
        return None

    def close(self) -> None:
        self.closed = True


class Exploding:
    def output(self, out: Output, progress: Progress) -> None:
        raise RuntimeError("presenter bug")

    def sample(self, sample: Sample, progress: Progress) -> None:
        raise RuntimeError("presenter bug")


@pytest.fixture
def link(sabertooth: Profile) -> FakeLink:
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    return FakeLink(FakeVehicle(sabertooth, W, r_g))


def run(session: Session, *, after: float | None = None, then: Any = None) -> Any:
    async def main() -> Any:
        task = asyncio.create_task(session.run())
        if after is not None:
            await asyncio.sleep(after)
            then()
        return await task
    return asyncio.run(main())


def test_session_runs_to_a_result_and_cleans_up(sabertooth: Profile, link: FakeLink) -> None:
    recorder = ListRecorder()
    out = io.StringIO()
    session = Session(link, sabertooth, recorder=recorder, confirmed=True,
                      presenters=[Exploding(), HeadlessPresenter(out, json_lines=True)])
    result = run(session)
    assert result.phase is Phase.DONE, result.reason
    assert abs(result.estimate.m_ext_kg - 10.0) < 0.05
    assert isinstance(link.sent[0], HoldAttitude) and isinstance(link.sent[-1], Release)
    assert link.closed and recorder.closed
    assert recorder.samples[0].t_s == 0.0  # session time starts at the first sample
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert lines[-1]["type"] == "result"
    assert lines[-1]["estimate"]["m_ext_kg"] == pytest.approx(result.estimate.m_ext_kg)
    assert {"state", "progress", "command"} <= {line["type"] for line in lines}


def test_operator_abort_releases(sabertooth: Profile, link: FakeLink) -> None:
    link.vehicle.stuck_at_deg = 5.0  # keeps the session running until the abort
    session = Session(link, sabertooth, recorder=None, presenters=[], confirmed=True)
    result = run(session, after=0.5, then=session.abort)
    assert result.phase is Phase.ABORTED
    assert isinstance(link.sent[-1], Release)


class SlowToConfirm(FakeLink):
    """A link whose hold waits for the vehicle's confirmation until a release comes (as
    the MAVLink link waits up to 3 s for the mode change)."""

    async def send(self, command: Command) -> None:
        await super().send(command)
        if isinstance(command, HoldAttitude):
            self.released = asyncio.Event()
            await self.released.wait()
        elif isinstance(command, Release):
            self.released.set()


def test_abort_is_not_held_up_by_a_command_awaiting_confirmation(
        sabertooth: Profile, link: FakeLink) -> None:
    slow = SlowToConfirm(link.vehicle)
    session = Session(slow, sabertooth, recorder=None, presenters=[], confirmed=True)

    async def until(condition: Any) -> None:
        while not condition():
            await asyncio.sleep(0.01)

    async def main() -> Any:                      # wait_for: hang guards, not timings
        task = asyncio.create_task(session.run())
        await asyncio.wait_for(until(lambda: slow.sent), 60)  # the hold is out, unconfirmed
        t_hold = slow.t
        await asyncio.wait_for(until(lambda: slow.t >= t_hold + 1.0), 60)  # samples flow on
        session.abort()
        return await asyncio.wait_for(task, 60)

    result = asyncio.run(main())
    assert result.phase is Phase.ABORTED
    assert [type(c) for c in slow.sent] == [HoldAttitude, Release]


def test_link_that_goes_quiet_mid_hold_is_released_within_a_second_of_its_last_sample(
        sabertooth: Profile, link: FakeLink) -> None:
    """The release's stamp is session time (the samples' clock, advanced by the wall
    clock while the link is quiet), as the recorder keeps it."""
    link.hang_at = 40.0
    recorder = ListRecorder()
    session = Session(link, sabertooth, recorder=recorder, presenters=[], confirmed=True)
    result = run(session)
    assert result.phase is Phase.FAILED and "link lost: no telemetry" in result.reason
    assert result.cause == "link"
    assert isinstance(link.sent[-1], Release) and link.closed
    last = recorder.samples[-1].t_s
    [t_release] = [t for t, c in recorder.commands if isinstance(c, Release)]
    assert last + sabertooth.procedure.link_timeout_s < t_release <= last + 1.0


class RawFakeLink(FakeLink):
    """A link that records its packets itself (as MAVLink does), and concludes that
    someone else took over mid-hold."""

    on_raw = None

    async def samples(self) -> Any:
        async for s in super().samples():
            yield s
            if self.t >= 30.0 and not getattr(self, "said", False):
                self.said = True
                yield PilotInput(self.t, "mode changed to MANUAL by another station")


def test_a_raw_link_s_pilot_input_is_recorded_though_its_packets_stand_for_the_rest(
        sabertooth: Profile, link: FakeLink) -> None:
    raw = RawFakeLink(link.vehicle)
    recorder = ListRecorder()
    result = run(Session(raw, sabertooth, recorder=recorder, presenters=[], confirmed=True))
    assert result.phase is Phase.FAILED and result.cause == "pilot"
    assert recorder.samples == [PilotInput(recorder.samples[0].t_s,
                                           "mode changed to MANUAL by another station")]
    assert isinstance(raw.sent[-1], Release)


def test_link_that_ends_fails_the_session(sabertooth: Profile, link: FakeLink) -> None:
    link.end_at = 20.0
    session = Session(link, sabertooth, recorder=None, presenters=[], confirmed=True)
    result = run(session)
    assert result.phase is Phase.FAILED and "the link closed" in result.reason
    assert isinstance(link.sent[-1], Release)


def test_waits_for_confirmation_then_commands(sabertooth: Profile, link: FakeLink) -> None:
    session = Session(link, sabertooth, recorder=None, presenters=[])

    async def main() -> Any:
        task = asyncio.create_task(session.run())
        while session.procedure.phase is not Phase.CONFIRM:
            await asyncio.sleep(0.01)
        assert link.sent == []
        session.confirm()
        return await task
    result = asyncio.run(main())
    assert result.phase is Phase.DONE


def test_a_vehicle_that_talks_but_never_connects_fails_after_the_connect_timeout(
        sabertooth: Profile) -> None:
    """Telemetry keeps coming, but the link never connects (no handshake): the connect
    timeout still runs, and the failure says what the link said."""
    from dataclasses import replace

    from trimd.core.samples import Attitude, Health

    class Unanswering:
        description = "unanswering"
        sent: ClassVar[list[Command]] = []

        async def samples(self) -> Any:
            while True:
                await asyncio.sleep(0.01)
                yield Attitude(0.0, 0, 0, 0, 0, 0, 0)
                yield Health(0.0, False, "MANUAL", True, detail="no handshake yet")

        async def send(self, command: Command) -> None:
            self.sent.append(command)

        async def close(self) -> None:
            return None

    quick = replace(sabertooth, procedure=replace(sabertooth.procedure, connect_timeout_s=0.5))
    result = run(Session(Unanswering(), quick, recorder=None, presenters=[], confirmed=True))
    assert result.phase is Phase.FAILED and result.cause == "link"
    assert result.reason == ("link lost: the vehicle did not connect within 0.5 s: "
                             "no handshake yet")
    assert Unanswering.sent == []


def test_no_vehicle_fails_after_the_connect_timeout(sabertooth: Profile) -> None:
    from dataclasses import replace

    from trimd.core.samples import Attitude

    class Silent:
        description = "silent"
        sent: ClassVar[list[Command]] = []

        async def samples(self) -> Any:
            await asyncio.sleep(0.05)
            yield Attitude(0.0, 0, 0, 0, 0, 0, 0)  # no heartbeat: the session never starts
            await asyncio.sleep(3600)

        async def send(self, command: Command) -> None:
            self.sent.append(command)

        async def close(self) -> None:
            return None

    quick = replace(sabertooth, procedure=replace(sabertooth.procedure, connect_timeout_s=0.5))
    result = run(Session(Silent(), quick, recorder=None, presenters=[], confirmed=True))
    assert result.phase is Phase.FAILED and result.cause == "link"
    assert "no heartbeat from the vehicle within 0.5 s" in result.reason
    assert Silent.sent == []


def test_stopping_before_the_vehicle_answers_leaves_a_clean_log_and_valid_json(
        sabertooth: Profile, tmp_path: Any) -> None:
    from trimd.logs.recorder import TlogRecorder
    from trimd.logs.tlog import TlogReader

    class Nobody:
        description = "nobody"

        async def samples(self) -> Any:
            await asyncio.sleep(3600)
            yield  # pragma: no cover - never reached

        async def send(self, command: Command) -> None:
            raise AssertionError("nothing may be sent")

        async def close(self) -> None:
            return None

    out = io.StringIO()
    log = tmp_path / "s.tlog"
    session = Session(Nobody(), sabertooth, recorder=TlogRecorder(log, sabertooth, ""),
                      presenters=[HeadlessPresenter(out, json_lines=True)], confirmed=True)
    result = run(session, after=0.2, then=lambda: session.abort("stopped by SIGTERM"))
    assert result.phase is Phase.ABORTED and result.reason == "stopped by SIGTERM"

    def no_nan(constant: str) -> None:
        raise AssertionError(f"{constant} is not JSON")

    lines = [json.loads(line, parse_constant=no_nan) for line in out.getvalue().splitlines()]
    assert lines[-1]["t_s"] == 0.0 and lines[-1]["text"] == "stopped by SIGTERM"
    reader = TlogReader.open(log)
    texts = [m.text for _, m in reader.messages() if m.get_type() == "STATUSTEXT"]
    assert "stopped by SIGTERM" in texts and reader.stats.bad_frames == 0


class _QuietAfterAHeartbeat:
    """A link with a heartbeat and an attitude, then silence (no samples, no end)."""

    description = "quiet"

    async def samples(self) -> Any:
        from trimd.core.samples import Attitude, Health

        yield Health(10.0, True, "ALT_HOLD", True)
        yield Attitude(10.0, 0, 0, 0, 0, 0, 0)
        await asyncio.sleep(3600)

    async def send(self, command: Command) -> None:
        return None

    async def close(self) -> None:
        return None


def test_a_quiet_link_still_gets_its_last_records_to_the_disk(sabertooth: Profile,
                                                              tmp_path: Any) -> None:
    """Nothing arrives after the first samples: the session's quiet-link ticks flush them
    (a kill -9 then loses at most a second), without waiting for the next write."""
    from dataclasses import replace

    from trimd.logs.recorder import TlogRecorder
    from trimd.logs.tlog import TlogReader

    log = tmp_path / "s.tlog"
    patient = replace(sabertooth, procedure=replace(sabertooth.procedure, link_timeout_s=1e9))
    session = Session(_QuietAfterAHeartbeat(), patient, confirmed=True, presenters=[],
                      recorder=TlogRecorder(log, sabertooth, ""))

    def on_disk() -> list[str]:
        return [m.get_type() for _, m in TlogReader(log.read_bytes()).messages()]

    async def main() -> list[str]:
        task = asyncio.ensure_future(session.run())
        for _ in range(200):  # a hang guard of 20 s, not a timed assertion
            await asyncio.sleep(0.1)
            if "ATTITUDE" in (kinds := on_disk()):
                assert not task.done()  # flushed while the session runs, not at its end
                break
        session.abort("test over")
        await task
        return kinds

    assert "ATTITUDE" in asyncio.run(main())  # read while the session still ran


@pytest.mark.parametrize("wall_clock", [True, False])
def test_only_a_live_link_times_out_on_the_wall_clock(sabertooth: Profile,
                                                      wall_clock: bool) -> None:
    from dataclasses import replace

    quick = replace(sabertooth, procedure=replace(sabertooth.procedure, link_timeout_s=0.2))
    session = Session(_QuietAfterAHeartbeat(), quick, recorder=None, presenters=[],
                      confirmed=True, wall_clock=wall_clock)

    async def main() -> Any:
        task = asyncio.ensure_future(session.run())
        await asyncio.sleep(1.0)  # five link timeouts of wall time
        session.abort("test over")
        return await task

    result = asyncio.run(main())
    if wall_clock:  # a live link that says nothing is lost
        assert result.phase is Phase.FAILED and result.cause == "link", result
    else:  # a recording's clock stands still while it is quiet (a paused replay)
        assert result.phase is Phase.ABORTED and result.reason == "test over", result


def test_headless_prints_each_link_warning_once_and_the_vehicle_s_messages() -> None:
    from trimd.core.procedure import Procedure
    from trimd.core.profile_yaml import load_profile
    from trimd.core.samples import Health, VehicleText

    out = io.StringIO()
    presenter = HeadlessPresenter(out)
    progress = Procedure(load_profile("bluerov2-heavy")).progress
    for t in (1.0, 2.0):
        presenter.sample(Health(t, True, "MANUAL", True, detail="MOT_1_DIRECTION is -1; x"),
                         progress)
    presenter.sample(VehicleText(3.0, 2, "Failsafe: pilot input lost, disarming"), progress)
    lines = out.getvalue().splitlines()
    assert lines == ["[     1.0 s] warning: MOT_1_DIRECTION is -1",
                     "[     1.0 s] warning: x",
                     "[     3.0 s] vehicle error: Failsafe: pilot input lost, disarming"]
