"""The simulated vehicle as an in-process link (``sim:`` URLs)."""

from __future__ import annotations

import asyncio
import itertools
import math
from collections import Counter

import pytest

from trimd.app.connect import open_link
from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.samples import (
    Arm,
    Attitude,
    Battery,
    Depth,
    Health,
    HoldAttitude,
    OpenLoop,
    Release,
    Sample,
    Thrusters,
    Velocity,
)
from trimd.drivers.sim.config import SimConfig, parse_sim_options
from trimd.drivers.sim.link import SimLink


async def _collect(link: SimLink, seconds: float) -> list[Sample]:
    """Samples stamped within the next ``seconds`` of simulated time."""
    out: list[Sample] = []
    t_end = link.vehicle.t_s + seconds
    async for s in link.samples():
        if s.t_s >= t_end - 1e-9:
            break
        out.append(s)
    return out


def test_options_syntax() -> None:
    c = parse_sim_options("payload=3.5@0.2,-0.1,0.05+-1@AftSB,seed=7,station=yes,"
                          "current_m_s=0.05")
    assert (c.payload, c.seed, c.station, c.current_m_s) == (
        "3.5@0.2,-0.1,0.05+-1@AftSB", 7, True, 0.05)
    assert parse_sim_options("") == SimConfig()
    for bad, hint in (("paylod=1@AftSB", "payload"), ("seed=x", "int"), ("dvl=maybe", "bool"),
                      ("1@AftSB", "KEY=VALUE")):
        with pytest.raises(LinkError, match=hint):
            parse_sim_options(bad)


def test_open_link_refuses_a_bad_payload(sabertooth: Profile) -> None:
    with pytest.raises(LinkError, match="no ballast slot"):
        asyncio.run(open_link("sim:payload=10@Keel", sabertooth))


@pytest.mark.parametrize(("url", "per_10_s"), [
    ("sim:dvl=1", {Attitude: 500, Thrusters: 500, Depth: 500, Velocity: 50}),
    ("sim:dvl=1,thrusters_hz=20", {Attitude: 500, Thrusters: 200, Depth: 500, Velocity: 50}),
])
def test_the_simulated_vehicle_streams_at_the_rate_asked(
        sabertooth: Profile, url: str, per_10_s: dict[type, int]) -> None:
    """As a MAVLink link asks the vehicle (``trimd excite``: 50 Hz), the simulator streams
    attitude, thruster outputs and depth at ``stream_hz`` unless its options set a rate;
    the DVL keeps its own 5 Hz."""
    async def scenario() -> Counter[type]:
        link = await open_link(url, sabertooth, stream_hz=50.0)
        got = Counter(type(s) for s in await _collect(link, 10.0))
        await link.close()
        return got

    counts = asyncio.run(scenario())
    assert {k: counts[k] for k in per_10_s} == per_10_s


def test_link_streams_in_simulated_time_and_obeys(sabertooth: Profile) -> None:
    async def scenario() -> None:
        link = await open_link("sim:payload=10@AftSB,seed=3,dvl=1", sabertooth)
        assert isinstance(link, SimLink)
        first = await _collect(link, 10.0)
        counts = Counter(type(s) for s in first)
        assert counts == {Attitude: 200, Thrusters: 100, Depth: 50, Velocity: 50,
                          Battery: 10, Health: 10}
        stamps = [s.t_s for s in first]
        assert stamps == sorted(stamps) and stamps[-1] <= 10.0
        assert all(len(s.pwm_us) == 6 for s in first if isinstance(s, Thrusters))

        await link.send(HoldAttitude(math.radians(10), math.radians(-5), 0.0))
        held = [s for s in await _collect(link, 60.0) if isinstance(s, Attitude)][-20:]
        assert all(abs(a.phi - math.radians(10)) < math.radians(0.5)
                   and abs(a.theta + math.radians(5)) < math.radians(0.5) for a in held)

        await link.send(Release())
        level = [s for s in await _collect(link, 60.0) if isinstance(s, Attitude)][-20:]
        assert all(abs(a.phi) < math.radians(0.5) and abs(a.theta) < math.radians(0.5)
                   for a in level)

        await link.send(OpenLoop((0.3, 0, 0, 0, 0, 0)))
        moving = await _collect(link, 20.0)
        assert [s.mode for s in moving if isinstance(s, Health)][-1] == "MANUAL"
        assert [s.u for s in moving if isinstance(s, Velocity)][-1] > 0.1   # surging ahead

        await link.send(Arm(False))
        off = await _collect(link, 2.0)
        assert not [s for s in off if isinstance(s, Health)][-1].armed
        assert [s for s in off if isinstance(s, Thrusters)][-1].pwm_us == (1500.0,) * 6

        assert "10@AftSB" in link.truth()
        assert link.vehicle.truth.m_ext_kg == 10.0
        await link.close()
        assert [s async for s in link.samples()] == []
        with pytest.raises(LinkError):
            await link.send(Release())

    asyncio.run(scenario())


def test_vehicle_clock_jump(sabertooth: Profile) -> None:
    """``clock_jump_s``: the sample stamps jump once; the samples keep coming at the same
    simulated pace."""
    async def stamps() -> list[float]:
        link = await open_link("sim:clock_jump_s=400,clock_jump_at_s=5", sabertooth)
        out = []
        async for s in link.samples():
            if isinstance(s, Attitude):
                out.append(s.t_s)
            if len(out) == 200:
                return out
        return out

    t = asyncio.run(stamps())
    jump = [b - a for a, b in itertools.pairwise(t) if b - a > 1.0]
    assert len(t) == 200 and jump == pytest.approx([400.05])
    assert max(x for x in t if x < 100) < 5.0 <= min(x for x in t if x > 100) - 400.0
