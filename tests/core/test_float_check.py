"""The float check's machine, driven by a synthetic floating vehicle (no I/O, no clock):
once let go it turns to its passive trim along a known damped response and sinks at a
known rate; the machine must find the trim to its ±, judge it, and release the vehicle on
every way out."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pytest

from trimd.core.events import Abort, Cause, Confirm, Event, Notice, Output, Phase, Tick
from trimd.core.float_check import DEPTH_STOP_SHARE, NEUTRAL, FloatCheck
from trimd.core.floating import (
    Z95,
    FloatResult,
    Verdict,
    float_result,
    float_timing,
    float_to_dict,
    remaining_transient_deg,
)
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Depth, Health, ModeClass, OpenLoop, PilotInput, Release

DT = 0.01


@dataclass
class Floater:
    """Level and at constant depth while held; let go (an :class:`OpenLoop`), its roll and
    pitch approach ``trim_deg`` as a damped oscillator of period ``period_s`` and damping
    ratio ``zeta`` and it sinks at ``sink_m_s``. Attitude at 20 Hz with white noise
    ``noise_deg``, depth at 5 Hz, health at 1 Hz."""

    trim_deg: tuple[float, float]
    period_s: float = 3.0
    zeta: float = 0.3
    sink_m_s: float = 0.0
    noise_deg: float = 0.05
    seed: int = 0
    angle: np.ndarray = field(default_factory=lambda: np.zeros(2))
    rate: np.ndarray = field(default_factory=lambda: np.zeros(2))
    depth: float = 10.0
    floating: bool = False
    commands: list[tuple[float, object]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    def apply(self, t: float, out: Output) -> None:
        if isinstance(out, Notice):
            return
        self.commands.append((t, out))
        self.floating = isinstance(out, OpenLoop)

    def samples(self, t: float) -> list[Event]:
        if self.floating:
            w = 2 * math.pi / self.period_s
            trim = np.radians(self.trim_deg)
            acc = -w * w * (self.angle - trim) - 2 * self.zeta * w * self.rate
            self.rate = self.rate + acc * DT
            self.angle = self.angle + self.rate * DT
            self.depth += self.sink_m_s * DT
        k = round(t / DT)
        out: list[Event] = []
        if k % 100 == 0:
            out.append(Health(t, True, "ALT_HOLD", True, mode_class=ModeClass.DEPTH_HOLDING))
        if k % 20 == 0:
            out.append(Depth(t, self.depth + 0.003 * self.rng.standard_normal()))
        if k % 5 == 0:
            noise = np.radians(self.noise_deg) * self.rng.standard_normal(2)
            phi, theta = self.angle + noise
            out.append(Attitude(t, float(phi), float(theta), 0.0, *self.rate, 0.0))
        return out


def run(check: FloatCheck, v: Floater, t_end: float = 600.0,
        at: dict[float, Event] | None = None, silent_after: float = math.inf
        ) -> list[tuple[float, Output]]:
    log: list[tuple[float, Output]] = []
    pending = dict(at or {})
    t = 0.0
    while t < t_end and not check.phase.final:
        t = round(t + DT, 6)
        events = [] if t > silent_after else v.samples(t)
        events += [pending.pop(w) for w in sorted(pending) if w <= t]
        events.append(Tick(t))
        for e in events:
            for out in check.step(e):
                log.append((t, out))
                v.apply(t, out)
    return log


def commands(log: list[tuple[float, Output]]) -> list[object]:
    return [o for _, o in log if not isinstance(o, Notice)]


@pytest.mark.parametrize(("trim", "longer"), [((0.3, -0.2), False), ((2.5, 0.4), True)])
def test_a_float_for_a_correction_collects_to_the_end_unless_level(
        bluerov: Profile, trim: tuple[float, float], longer: bool) -> None:
    """Not level: its angles feed a correction, so it collects to collect_max_s (the
    attitude reference's wander averages down); level: it stops as soon as any float."""
    results, said = [], []
    for for_correction in (False, True):
        check = FloatCheck(bluerov, confirmed=True, for_correction=for_correction)
        log = run(check, Floater(trim))
        assert check.phase is Phase.DONE, check.reason
        assert isinstance(check.verification, FloatResult)
        results.append(check.verification)
        said.append([o.text for _, o in log if isinstance(o, Notice) and o.kind == "info"])
    plain, corrected = results
    assert said == [[], ["not level so far: collecting on to collect_max_s (120 s) or the "
                         "depth envelope, for the correction"] if longer else []]
    span = [r.t_end_s - r.t_start_s for r in results]
    if longer:
        assert span[1] >= bluerov.procedure.collect_max_s > 2 * span[0], span
        assert corrected.verdict is plain.verdict is Verdict.NOT_LEVEL
        assert abs(corrected.roll_deg - trim[0]) < 0.02      # 20 Hz noise of 0.05°
    else:
        assert corrected == plain


@pytest.mark.parametrize(("trim", "verdict"), [((0.3, -0.2), Verdict.LEVEL),
                                                ((2.5, 0.4), Verdict.NOT_LEVEL)])
def test_finds_the_passive_trim_and_judges_it(bluerov: Profile, trim: tuple[float, float],
                                              verdict: Verdict) -> None:
    v = Floater(trim)
    check = FloatCheck(bluerov, confirmed=True)
    log = run(check, v)
    assert check.phase is Phase.DONE, check.reason
    r = check.verification
    assert isinstance(r, FloatResult)
    for got, std, want in ((r.roll_deg, r.roll_std_deg, trim[0]),
                           (r.pitch_deg, r.pitch_std_deg, trim[1])):
        assert abs(got - want) <= Z95 * std and abs(got - want) < 0.1
        # the AHRS's own error is in the ±, and it is most of it
        assert bluerov.attitude_error_deg <= std < 1.5 * bluerov.attitude_error_deg
    assert r.verdict is verdict
    assert commands(log) == [NEUTRAL, Release()]
    result = [o for _, o in log if isinstance(o, Notice) and o.kind == "result"]
    assert len(result) == 1 and result[0].verification is r
    assert float_to_dict(r)["verdict"] == verdict.value


def test_nothing_is_commanded_before_the_confirmation(bluerov: Profile) -> None:
    v = Floater((0.0, 0.0))
    check = FloatCheck(bluerov)
    log = run(check, v, t_end=40.0)
    assert check.phase is Phase.CONFIRM and commands(log) == []
    log = run(check, v, t_end=41.0, at={0.0: Confirm()})
    assert commands(log)[:1] == [NEUTRAL]


def test_a_sinking_vehicle_is_released_and_the_reason_says_why(bluerov: Profile) -> None:
    """Sinking 0.2 m/s, the float reaches 80 % of the 0.5 m envelope in 2 s: before the
    attitude has settled (two windows of a period), so no result, FAILED, released."""
    v = Floater((1.0, 1.0), sink_m_s=0.2)
    check = FloatCheck(bluerov, confirmed=True)
    log = run(check, v)
    assert check.phase is Phase.FAILED and check.cause is Cause.ENVELOPE
    assert "sinks at about 0.2" in check.reason and "W − B > 0" in check.reason
    assert commands(log)[-1] == Release() and check.verification is None
    released = next(t for t, o in log if isinstance(o, Release))
    moved = abs(v.depth - 10.0)
    assert moved < bluerov.procedure.max_depth_excursion_m
    assert moved >= DEPTH_STOP_SHARE * bluerov.procedure.max_depth_excursion_m - 0.05
    assert released < 10.0


def test_a_slow_sinker_ends_with_what_was_collected(bluerov: Profile) -> None:
    """Sinking slowly, the float collects for a while before the depth stops it (a level
    tolerance of 0.02° is not reached in 20 s): done, the result says why collecting
    stopped."""
    v = Floater((0.5, -0.5), sink_m_s=0.018)
    check = FloatCheck(replace(bluerov, level_tol_deg=0.02), confirmed=True)
    run(check, v)
    assert check.phase is Phase.DONE, check.reason
    r = check.verification
    assert r is not None and r.stopped.startswith("depth +0.4")
    assert r.depth_rate_m_s == pytest.approx(0.018, abs=0.003)


def test_a_riser_released_before_it_settled_gives_where_its_approach_ends(
        sabertooth: Profile) -> None:
    """The Sabertooth's pitch relaxes in ≈ 21 s (over-damped), and rising 0.15 m/s it
    reaches 80 % of a 10 m envelope after ≈ 53 s: two windows seen, but 0.12° of its
    1.5° approach still to come, which the last window's mean falls short by. The float
    ends with where the approach since letting go ends (fitted, both axes over-damped):
    the trim to a hundredth of a degree, within the 95 % interval, NOT level; released;
    the reason says why it stopped."""
    w = 2 * math.pi / float_timing(sabertooth).period_s[1]
    slow = 1 / float_timing(sabertooth).relax_s[1]   # the slow pole ω·(ζ − √(ζ² − 1))
    zeta = (slow / w + w / slow) / 2
    v = Floater((0.2, 1.5), period_s=2 * math.pi / w, zeta=zeta, sink_m_s=-0.15)
    seen: list[Attitude] = []
    samples = v.samples

    def recorded(t: float) -> list[Event]:
        out = samples(t)
        seen.extend(s for s in out if isinstance(s, Attitude))
        return out

    v.samples = recorded  # type: ignore[method-assign]
    check = FloatCheck(sabertooth, confirmed=True, depth_excursion_m=10.0)
    log = run(check, v)
    assert check.phase is Phase.DONE, check.reason
    r = check.verification
    assert r is not None and "before the attitude settled" in r.stopped, r
    assert r.stopped.startswith("depth -8.0")
    collected = [a.theta for a in seen if r.t_start_s <= a.t_s <= r.t_end_s]
    assert 1.5 - math.degrees(float(np.mean(collected))) > 0.1   # the mean falls short
    assert r.approach == (True, True) and abs(r.pitch_deg - 1.5) < 0.01
    for got, std, want in ((r.roll_deg, r.roll_std_deg, 0.2),
                           (r.pitch_deg, r.pitch_std_deg, 1.5)):
        assert abs(got - want) <= Z95 * std, r
    assert r.verdict is Verdict.NOT_LEVEL
    assert commands(log) == [NEUTRAL, Release()]


def test_released_while_settling_the_result_takes_two_batches(bluerov: Profile) -> None:
    """The Heavy's window is one batch (its roll period): stopped by the depth just after
    two windows, still settling, the result reaches back two batches, so its ± is finite
    (one batch has no batch-means σ) and holds the trim."""
    v = Floater((1.0, -0.6), period_s=3.6, zeta=0.02, sink_m_s=0.053)
    check = FloatCheck(bluerov, confirmed=True)
    run(check, v)
    r = check.verification
    assert check.phase is Phase.DONE and r is not None, check.reason
    assert "before the attitude settled" in r.stopped, r
    assert r.t_end_s - r.t_start_s >= 2 * float_timing(bluerov).batch_s - 0.2
    for got, std, want in ((r.roll_deg, r.roll_std_deg, 1.0), (r.pitch_deg, r.pitch_std_deg,
                                                               -0.6)):
        assert math.isfinite(std) and abs(got - want) <= Z95 * std, r


def test_more_depth_change_when_the_operator_allows_it(bluerov: Profile) -> None:
    v = Floater((1.0, 1.0), sink_m_s=0.2)
    check = FloatCheck(bluerov, confirmed=True, depth_excursion_m=20.0)
    run(check, v)
    assert check.phase is Phase.DONE, check.reason


@pytest.mark.parametrize("how", ["abort", "link", "silence", "pilot"])
def test_every_way_out_releases_at_once(bluerov: Profile, how: str) -> None:
    v = Floater((0.5, 0.5))
    check = FloatCheck(bluerov, confirmed=True)
    t_stop = 8.0
    event: dict[float, Event] = {
        "abort": {t_stop: Abort()}, "link": {t_stop: Health(t_stop, False, "", False)},
        "pilot": {t_stop: PilotInput(t_stop, "sticks")}, "silence": {}}[how]
    log = run(check, v, at=event, silent_after=t_stop if how == "silence" else math.inf)
    assert check.phase in (Phase.FAILED, Phase.ABORTED)
    released = [t for t, o in log if isinstance(o, Release)]
    assert len(released) == 1
    assert t_stop <= released[0] <= t_stop + 1.0
    assert check.verification is None


def test_floating_beyond_the_tilt_limit_ends_it(bluerov: Profile) -> None:
    v = Floater((bluerov.procedure.max_tilt_deg + 2.0, 0.0), zeta=0.8)
    check = FloatCheck(bluerov, confirmed=True)
    log = run(check, v)
    assert check.phase is Phase.FAILED and "beyond the tilt limit" in check.reason
    assert commands(log) == [NEUTRAL, Release()]


def test_timing_from_the_profiles_dynamics(bluerov: Profile, sabertooth: Profile) -> None:
    """The Heavy oscillates (period 2π·√(J/k), k = −B·z_b); the Sabertooth's pitch is
    heavily over-damped: its slow pole c/k ≈ 21 s sets the settling windows."""
    heavy = float_timing(bluerov)
    J = bluerov.inertia_kg_m2[0] + bluerov.added_mass[3]
    k = -bluerov.buoyancy_N * bluerov.r_b_m[2]
    assert heavy.period_s[0] == pytest.approx(2 * math.pi * math.sqrt(J / k))
    assert not any(heavy.damped) and heavy.window_s == pytest.approx(heavy.period_s[0])
    saber = float_timing(sabertooth)
    k = -sabertooth.buoyancy_N * sabertooth.r_b_m[2]
    assert all(saber.damped)
    assert saber.relax_s[1] == pytest.approx(-sabertooth.linear_damping[4] / k, rel=0.05)
    assert saber.window_s == pytest.approx(saber.relax_s[1])


def test_batch_means_average_an_oscillation_out(bluerov: Profile) -> None:
    """Undamped roll oscillating ±2° about 0.7° for ten periods: the mean is 0.7°, the
    batch-means σ about nothing, no transient left."""
    timing = float_timing(bluerov)
    t = np.arange(0.0, 10 * timing.batch_s, 0.05)
    roll = 0.7 + 2.0 * np.sin(2 * math.pi * t / timing.batch_s + 0.3)
    angles = np.column_stack([roll, np.full_like(t, -0.4)])
    r = float_result(t, angles, [(0.0, 5.0), (t[-1], 5.0)], timing=timing, profile=bluerov,
                     settle_s=0.0, depth_change_m=0.0)
    assert r.roll_deg == pytest.approx(0.7, abs=0.02)
    assert r.stat_std_deg[0] < 0.01 and r.transient_deg[0] < 0.05
    rem = remaining_transient_deg(t, angles, timing)
    assert rem is not None and rem.max() < 0.05
