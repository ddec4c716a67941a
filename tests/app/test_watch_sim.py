"""The passive watch on the simulated BlueROV2 Heavy during a scripted dive (simulated
time, faster than real time): it never commands, its segments see the true W − B, and a
leak or a lost piece raises an alert with the change inside its ±."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import numpy as np
import pytest

from trimd.app.watch import Record, watch_link
from trimd.core.motion import MAX_SPEED_M_S
from trimd.core.profile_yaml import load_profile
from trimd.core.samples import Attitude, Command, Sample
from trimd.core.watch import TrimWatch, WatchAlert, WatchSegment
from trimd.drivers.sim.config import parse_sim_options
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.scenario import TRANSITS, TRANSITS_RAMP_S
from trimd.drivers.sim.vehicle import SimVehicle

PROFILE = "bluerov2-heavy"
#: the longest the leak of 0.5 N/min may take to alert [s of simulated time] (the dive ends
#: then: one that had not alerted by then fails)
LEAK_ALERT_WITHIN_S = 300.0


class PassiveSimLink(SimLink):
    """The simulated vehicle, failing any test that sends it a command; ``speeds``: the
    true horizontal speed through the water [m/s] at each attitude sample's time [s]."""

    def __init__(self, vehicle: SimVehicle) -> None:
        super().__init__(vehicle)
        self.speeds: list[tuple[float, float]] = []

    async def samples(self) -> AsyncIterator[Sample]:
        async for s in super().samples():
            if isinstance(s, Attitude):
                self.speeds.append((s.t_s, float(np.hypot(*self.vehicle.truth.nu[:2]))))
            yield s

    async def send(self, command: Command) -> None:
        raise AssertionError(f"the watch sent {command!r}")


def _watch(options: str, duration_s: float, link: list[PassiveSimLink] | None = None
           ) -> tuple[TrimWatch, SimVehicle, list[Record]]:
    profile = load_profile(PROFILE)
    vehicle = SimVehicle(profile, parse_sim_options(options))
    watch = TrimWatch(profile)
    records: list[Record] = []
    passive = PassiveSimLink(vehicle)
    if link is not None:
        link.append(passive)
    asyncio.run(watch_link(passive, watch, records.append, until_s=duration_s))
    return watch, vehicle, records


@pytest.mark.slow
def test_a_dive_without_change_gives_segments_at_the_true_net_force() -> None:
    watch, vehicle, records = _watch("pilot=dive,seed=1", 400.0)
    segments = [r for r in records if isinstance(r, WatchSegment)]
    assert len(segments) >= 3 and not watch.alerts
    assert watch.detector is not None   # the first three level segments made the baseline
    true_q = vehicle.truth.mass.net
    for s in segments:
        e = s.estimate
        assert e.observable == (True, True, True, False)
        assert abs(e.q[0] - true_q[0]) < 3 * e.q_std[0], (e.q, true_q, e.q_std)
        assert np.all(np.abs(e.q[1:3] - true_q[1:3]) < 3 * e.q_std[1:3] + 1e-3)
    # the transit and the turn of the script are not segments
    assert all(not (s.estimate.t_end_s > 90 and s.estimate.t_start_s < 130) for s in segments)


def test_a_dive_of_level_transits_gives_a_segment_at_each_stop_and_none_in_transit() -> None:
    """The transits pilot (a 20 s transit ending in a turn, then 40 s stopped, level
    throughout with ArduSub's stiffer attitude loop): each stop gives a segment at the
    true W − B, no segment starts before the sticks are back at neutral or touches the
    next transit, and through every segment the vehicle is at rest in the water (the
    coast after a transit does not count)."""
    link: list[PassiveSimLink] = []
    watch, vehicle, _ = _watch("pilot=transits,attitude_bandwidth_rad_s=6,seed=5", 250.0, link)
    spans = [(s.estimate.t_start_s, s.estimate.t_end_s) for s in watch.segments]
    stops, t = [], 0.0
    for duration, sticks in TRANSITS * 2:
        if not any(sticks):
            stops.append((t + TRANSITS_RAMP_S, t + duration))
        t += duration
    for a, b in stops[:4]:                      # the stops that ended within 250 s
        assert any(a <= t0 and t1 <= b for t0, t1 in spans), ((a, b), spans, watch.rejected)
    assert all(any(a <= t0 and t1 <= b for a, b in stops) for t0, t1 in spans), spans
    speeds = np.array(link[0].speeds)
    for t0, t1 in spans:
        inside = speeds[(speeds[:, 0] >= t0) & (speeds[:, 0] <= t1), 1]
        assert inside.max() < MAX_SPEED_M_S, (t0, t1, inside.max())
    true_q = vehicle.truth.mass.net
    for s in watch.segments:
        assert abs(s.estimate.q[0] - true_q[0]) < 3 * s.estimate.q_std[0]


@pytest.mark.slow
def test_no_alert_over_ten_minutes_without_change() -> None:
    """(The false alarms per hour over hours of dives are ``make bench``'s: bench_watch.)"""
    watch, _, _ = _watch("pilot=dive,seed=2,disturb=real", 600.0)
    assert len(watch.segments) >= 5
    assert not watch.alerts, [a.text for a in watch.alerts]


@pytest.mark.slow
def test_a_leak_is_alerted_soon_with_its_size_inside_the_interval() -> None:
    rate, start = 0.5, 300.0
    watch, _, records = _watch(f"pilot=dive,seed=3,leak_N_min={rate},leak_start_s={start}",
                               start + LEAK_ALERT_WITHIN_S)
    alerts = [r for r in records if isinstance(r, WatchAlert)]
    assert alerts, watch.rejected
    first = alerts[0].alert
    assert first.component == 0 and first.total > 0
    assert first.at_s - start <= LEAK_ALERT_WITHIN_S
    # the alerting segment's change against the water in at its middle
    seg = next(s.estimate for s in watch.segments if s.estimate.t_end_s == first.at_s)
    leaked = rate / 60 * ((seg.t_start_s + seg.t_end_s) / 2 - start)
    assert abs(first.total - leaked) < 3 * first.total_std, (first, leaked)
    assert "heavier by" in alerts[0].text
    assert not any(a.alert.component != 0 for a in alerts)  # the water is at CG0


@pytest.mark.slow
def test_a_dropped_piece_is_alerted_with_its_weight_and_moment() -> None:
    profile = load_profile(PROFILE)
    piece = next(x for x in profile.inventory if x.name == "lead-200g")
    w = (piece.mass_kg - profile.water_density_kg_m3 * piece.volume_m3) * profile.gravity_m_s2
    x_slot = profile.slot("W-aft-ctr").position_m[0]
    watch, _, records = _watch("pilot=dive,seed=4,drop=lead-200g@W-aft-ctr@400", 700.0)
    by_component = {r.alert.component: r.alert for r in records if isinstance(r, WatchAlert)}
    assert set(by_component) >= {0, 1}, [a.text for a in watch.alerts]
    force, pitch = by_component[0], by_component[1]
    assert force.total == pytest.approx(-w, abs=3 * force.total_std)
    assert pitch.total == pytest.approx(-w * x_slot, abs=3 * pitch.total_std)
    assert force.since_s >= 400.0 - 60 and force.at_s <= 400.0 + 300
