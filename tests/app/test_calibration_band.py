"""The band calibration (``trimd calibrate --band``, issue 24): on a trimmed vehicle, the
load that makes it just heavy enough for its vertical thrusters to hunt at the upper
edges of their dead bands, which the second hold shows (docs/method.md §7)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from tests.app.test_calibration import OPTIONS, PAYLOAD
from tests.helpers import ballast_payload, sim_trim
from trimd.app.calibrate import calibrate_with_weights
from trimd.app.calibration_loads import Load
from trimd.app.connect import open_link
from trimd.app.history import History
from trimd.app.replay import replay_calibration
from trimd.ballast.band import BAND_SHARE, band_load, band_margin_N, band_target, unhunted
from trimd.ballast.propose import Proposal
from trimd.cli.main import main
from trimd.core.errors import UsageError
from trimd.core.hunting import LIFTING, EdgeObservation
from trimd.core.link import Link
from trimd.core.model import band_at, restoring_matrix, thrust_configuration, thrust_from_pwm
from trimd.core.output_hist import spikes_seen
from trimd.core.profile import Profile
from trimd.core.profile_yaml import read_profile_text
from trimd.logs.recorder import TlogRecorder

SEED = 1


def test_the_band_aim_has_each_lifting_thruster_push_half_its_first_microsecond(
        bluerov: Profile, sabertooth: Profile) -> None:
    """Held level, the vehicle :func:`band_target` aims at is held by each lifting
    thruster with half the thrust of its first µs beyond its band's edge on that side (the
    Sabertooth's three, whose Z, K and M fix each one's thrust; the Heavy's four, whose
    least-norm allocation does), not merely by their sum."""
    for profile in (bluerov, sabertooth):
        T = thrust_configuration(profile.thrusters)
        lifting = [i for i in range(len(profile.thrusters)) if abs(T[2, i]) >= LIFTING]
        v = profile.nominal_voltage_V
        for upward in (True, False):
            aim = band_target(profile, upward)
            tau = restoring_matrix(0.0, 0.0)[:, :3] @ aim
            f = np.linalg.lstsq(T[2:5][:, lifting], tau[2:5], rcond=None)[0]
            first = []
            for i in lifting:
                low, high = band_at(profile.thrusters[i].curve, v)
                pwm = high + 1 if (T[2, i] < 0) == upward else low - 1
                first.append(float(thrust_from_pwm(profile.thrusters[i].curve, pwm, v)))
            assert f == pytest.approx(BAND_SHARE * np.array(first), rel=1e-9), profile.name
            assert aim[0] == pytest.approx(band_margin_N(profile, upward) * (1 if upward
                                                                            else -1))


def test_a_band_hold_misses_the_lifting_thrusters_without_a_spike_on_the_loads_side(
        sabertooth: Profile) -> None:
    """:func:`unhunted`: of the Sabertooth's three lifting thrusters, those whose hold shows
    no hunting spike at the edge at which they lift (the upper load) or push down (the
    lower): a spike on the other side, or of a horizontal thruster, does not count."""
    T = thrust_configuration(sabertooth.thrusters)
    lifting = [i for i in range(len(sabertooth.thrusters)) if abs(T[2, i]) >= LIFTING]
    horizontal = next(i for i in range(len(sabertooth.thrusters)) if i not in lifting)
    assert len(lifting) == 3
    first, second, third = lifting

    def spike(i: int, lifts: bool) -> EdgeObservation:
        above = (T[2, i] < 0) == lifts      # FRD: a thruster lifts with its thrust along −z
        return EdgeObservation(i, above, 1550.0, 1549.5, 0.0, 0.5, 1.0)

    spikes = [spike(first, True), spike(second, False), spike(horizontal, True)]
    assert unhunted(sabertooth, spikes, upward=True) == (second, third)
    assert unhunted(sabertooth, spikes, upward=False) == (first, third)
    assert unhunted(sabertooth, [], upward=True) == tuple(lifting)
    assert unhunted(sabertooth, [spike(i, True) for i in lifting], upward=True) == ()


def test_the_band_load_makes_the_aim_and_says_when_the_slots_cannot_take_it(
        bluerov: Profile, sabertooth: Profile) -> None:
    """The load turns the vehicle held level into the aim, W − B and both net moments:
    weights where it is too light, floats' lift where too heavy, on whichever side the
    moments need them."""
    for profile, q, upward in ((bluerov, (-1.3, 0.0, 0.0), True),
                               (bluerov, (2.0, 0.01, -0.02), True),
                               (sabertooth, (-8.0, 1.5, -0.7), True),
                               (bluerov, (-1.3, -0.03, 0.0), False),
                               (bluerov, (0.1, 0.0, 0.02), False),
                               (sabertooth, (8.0, -2.0, 0.4), False)):
        load = band_load(profile, q, upward)
        forces = np.array([f for _, f in load.pieces])
        where = np.array([profile.slot(s).position_m for s, _ in load.pieces])
        aim = band_target(profile, upward)
        assert load.aim == pytest.approx(tuple(aim)) and load.margin_N == load.aim[0]
        assert forces.sum() == pytest.approx(aim[0] - q[0])
        made = forces @ where[:, :2]
        assert made + load.miss_Nm == pytest.approx(aim[1:] - np.array(q[1:]), abs=1e-9)
        assert np.abs(load.miss_Nm).max() < 1e-3         # a piece is worth a mN·m
        for s, f in load.pieces:
            slot = profile.slot(s)
            assert f <= slot.max_weight_kg * profile.gravity_m_s2 + 1e-9
            assert -f <= slot.max_float_kg * profile.gravity_m_s2 + 1e-9
    # moments known to ± 0.3 N·m only: moved by 0.39·(1 − 0.3²/0.39²) ≈ 0.16 along x,
    # nothing along y (0.10 is within 1σ), to within σ/3, with fewer pieces
    exact, known = (band_load(bluerov, (-3.72, -0.39, 0.10), True, sd)
                    for sd in ((0.5, 0.0, 0.0), (0.5, 0.3, 0.3)))
    made = sum(f * np.array(bluerov.slot(s).position_m[:2]) for s, f in known.pieces)
    assert made == pytest.approx((0.39 - 0.3**2 / 0.39, 0.0), abs=0.1 + 1e-9), known
    assert len(known.pieces) < len(exact.pieces), (exact, known)
    assert sum(f for _, f in known.pieces) == pytest.approx(sum(f for _, f in exact.pieces))
    for upward in (True, False):           # a vehicle at its aim already: nothing to hang
        there = band_load(sabertooth, band_target(sabertooth, upward), upward, (1.0, 0.5, 0.5))
        assert there.pieces == () and there.miss_Nm == pytest.approx((0.0, 0.0), abs=1e-9)
    with pytest.raises(UsageError, match="weight slots take"):
        band_load(bluerov, (-500.0, 0.0, 0.0))


def test_a_band_load_search_stopped_without_a_load_says_so(
        bluerov: Profile, monkeypatch: pytest.MonkeyPatch) -> None:
    """A search that ends without any load (only the node limit can: the misses' slack
    keeps the problem feasible) is a UsageError naming the solver's reason, not a
    traceback."""
    monkeypatch.setattr("trimd.ballast.band.solve", lambda *_args: SimpleNamespace(
        x=None, message="Node limit reached."))
    with pytest.raises(UsageError, match=r"no band load found \(Node limit reached"):
        band_load(bluerov, (-1.3, 0.0, 0.0))


def test_the_band_loads_search_prints_nothing_on_standard_output(
        bluerov: Profile, capfd: pytest.CaptureFixture[str]) -> None:
    """HiGHS prints a debug line from C to descriptor 1 on some searches (HiGHS issue
    2783), which would land among ``trimd calibrate --json``'s output: this search made it
    print before the band load went through :func:`trimd.ballast.highs.solve`."""
    load = band_load(bluerov, (1.4685, 0.4102, -0.3283), False, (0.2413, 0.0566, 0.0431))
    assert load.pieces and capfd.readouterr().out == ""


@pytest.mark.slow
def test_the_band_holds_show_the_edges_of_the_trimmed_vehicles_vertical_thrusters(
        tmp_path: Path, bluerov: Profile) -> None:
    """The perturbed Heavy trimmed, its proposal fitted, then ``calibrate --band``: the
    loads trimd chooses, aimed again from each hold that misses a lifting thruster's edge,
    make the TRUE vehicle as heavy (then as buoyant) as it aims (within twice the first
    hold's ± of W − B); the last hold of each side shows every vertical thruster's edge
    on that side, each where the simulated ESC's really is; every experiment is learnt,
    and the recordings replay to them."""
    trial = sim_trim(bluerov, PAYLOAD, SEED, OPTIONS)
    proposal = trial.result.proposal
    assert isinstance(proposal, Proposal), trial.result.reason
    extra = ballast_payload(proposal, bluerov)
    loads: list[Load] = []

    def carried(load: Load) -> str:
        return "".join(f"+{w.kg:.6f}@{','.join(map(str, bluerov.slot(w.slot).position_m))}"
                       for w in load)

    def opener() -> Awaitable[Link]:
        now = carried(loads[-1]) if loads else ""      # each load swapped for the next
        return open_link(f"sim:payload={PAYLOAD}+{extra}{now},"
                         f"seed={SEED + 10 * (1 + len(loads))},truth_seed={SEED},{OPTIONS}",
                         bluerov)

    asked: list[str] = []

    def hang(text: str, load: Load) -> bool:
        asked.append(text)
        loads.append(load)
        return True

    yaml_text = read_profile_text(bluerov.name)[0]

    def record(hold: dict[str, object]) -> TlogRecorder:
        return TlogRecorder(tmp_path / f"hold{hold['hold']}.tlog", bluerov, yaml_text,
                            calibration_hold=hold)

    done = asyncio.run(calibrate_with_weights(opener, bluerov, (), hang, db=None,
                                              vehicle="rov", wall_clock=False, record=record,
                                              band_pct=1.0))
    sides = list(done.sides)
    # seed 1: the upper side took three holds, the lower two (docs/method.md §7)
    assert sides == [True] * 3 + [False] * 2 and len(loads) == len(sides), asked
    assert "upper band edge " in asked[0] and "take " not in asked[0], asked
    assert "W − B -1.36 ± 0.47 N" in asked[0], asked
    lower = sides.index(False)
    assert "lower band edge " in asked[lower] and "take " in asked[lower], asked
    # seed 1: the first upper load missed two thrusters' edges, the second one
    assert asked[1].startswith("the last hold did not show motor6, motor8 hunting at the "
                               "upper edge of their dead bands: the load aimed again; the "
                               "vehicle held level without its load at W − B -1.59 ± 0.25 N"
                               ), asked
    assert "W − B -1.49 ± 0.07 N" in asked[2], asked
    T = thrust_configuration(bluerov.thrusters)
    lifting = [i for i in range(len(bluerov.thrusters)) if abs(T[2, i]) >= LIFTING]
    true_offsets = trial.vehicle.offset.band_offsets_us
    known = np.sqrt(done.experiments[0].q_before_cov[0, 0])   # the first hold's ± on W − B
    for last, upward in ((lower - 1, True), (len(sides) - 1, False)):
        aimed = band_margin_N(bluerov, upward) * (1 if upward else -1)
        true_w_minus_b = trial.vehicle.ballasted(f"{extra}{carried(loads[last])}").net[0]
        assert abs(true_w_minus_b - aimed) <= 2 * known, (true_w_minus_b, aimed, known)
        after = done.experiments[last].after.outputs
        assert after is not None
        shown = [o for o in spikes_seen(after, bluerov) if o.thruster in lifting
                 and o.positive == ((T[2, o.thruster] < 0) == upward)]
        assert {o.thruster for o in shown} == set(lifting), (upward, shown)
        for o in shown:
            assert abs(o.offset_us - true_offsets[o.thruster][int(o.positive)]) <= 1.0, o
    assert all(o.accepted for o in done.outcomes), [o.message for o in done.outcomes]
    again = asyncio.run(replay_calibration([str(tmp_path / f"hold{k}.tlog")
                                            for k in range(len(loads) + 1)], None))
    assert [o.message for o in again.outcomes] == [o.message for o in done.outcomes]
    assert again.sides == done.sides


def test_trimd_calibrate_band_says_what_to_hang_and_checks_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``trimd calibrate --band --yes --json`` on a served simulator nobody hangs anything
    on: after the first hold it says what to hang and where for the upper edges; the
    second hold, which sees none of that load, is rejected as the load never put on,
    stored so, and the series stops there (a load aimed from it would be aimed from a
    vehicle that is not what the hold read), saying what to check; exit 1."""
    code = main(["calibrate", "--link", "sim:seed=4,truth=perturbed", "--profile",
                 "bluerov2-heavy", "--band", "--yes", "--json", "--no-record", "--hold-s",
                 "30", "--db", str(tmp_path / "trimd.db")])
    out, err = capsys.readouterr()
    done = json.loads(out)
    assert code == 1 and not done["accepted"], (out, err)
    assert ("x, y net moments -0.39 ± 0.06, +0.10 ± 0.11 N·m; for each vertical thruster to "
            "hunt at its upper band edge it should be heavy at +0.13 N, +0.00, +0.00 N·m (its "
            "W − B is known to ± 0.48 N only") in err, err
    assert "the load may miss it" in err
    # x moved by nearly all its 0.39 N·m (6σ), y (within 1σ) left
    assert ("the load leaving the moments +0.012, -0.097 N·m off it: hang 0.393 kg (its weight "
            "in water) at slot W-front-ctr, clear") in err, err
    assert "band edge" not in err.split("clear of the thrusters")[1], err   # one load only
    first, = done["experiments_run"]
    assert not first["accepted"] and "W-front-ctr" in first["label"], first
    assert first["band_edges_side"] == "upper", first
    assert "the known weight" in first["message"], first["message"]
    assert "check that what is hung is what trimd asked for" in done["stopped"], done
    with History(tmp_path / "trimd.db") as h:
        stored = [r.values["accepted"] for r in h.experiments("bluerov2-heavy")]
    assert stored == [False], stored
