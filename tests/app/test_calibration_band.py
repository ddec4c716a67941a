"""The band calibration (``trimd calibrate --band``, issue 24): on a trimmed vehicle, the
load that makes it just heavy enough for its vertical thrusters to hunt at the upper
edges of their dead bands, which the second hold shows (docs/method.md §7)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable
from pathlib import Path

import numpy as np
import pytest

from tests.app.test_calibration import OPTIONS, PAYLOAD
from tests.helpers import ballast_payload, sim_trim
from trimd.app.calibrate import Load, calibrate_with_weights
from trimd.app.connect import open_link
from trimd.app.history import History
from trimd.app.replay import replay_calibration
from trimd.ballast.propose import Proposal
from trimd.cli.main import main
from trimd.core.band import band_load, band_margin_N
from trimd.core.calibration import edges_of
from trimd.core.errors import UsageError
from trimd.core.hunting import LIFTING
from trimd.core.link import Link
from trimd.core.model import thrust_configuration
from trimd.core.profile import Profile
from trimd.core.profile_yaml import read_profile_text
from trimd.logs.recorder import TlogRecorder

SEED = 1


def test_the_band_load_cancels_its_moments_and_says_when_the_slots_cannot_take_it(
        bluerov: Profile, sabertooth: Profile) -> None:
    """The load aims W − B at the margin (heavy for the upper edges, buoyant for the lower
    ones), at slots whose x and y moments cancel: weights for a vehicle lighter than
    that, floats' lift for one heavier."""
    for profile, w_minus_b, upward in ((bluerov, -1.3, True), (bluerov, 2.0, True),
                                       (sabertooth, -8.0, True), (bluerov, -1.3, False),
                                       (bluerov, 0.1, False), (sabertooth, 8.0, False)):
        load = band_load(profile, w_minus_b, upward)
        forces = np.array([f for _, f in load.pieces])
        where = np.array([profile.slot(s).position_m for s, _ in load.pieces])
        aim = band_margin_N(profile, upward) * (1 if upward else -1)
        assert load.margin_N == pytest.approx(aim) and aim * (1 if upward else -1) > 0
        assert forces.sum() == pytest.approx(aim - w_minus_b)
        assert np.all(np.sign(forces) == np.sign(forces.sum()))
        assert np.allclose(forces @ where[:, :2], 0.0, atol=1e-9)
        assert load.moment_Nm == pytest.approx((0.0, 0.0), abs=1e-9)
    with pytest.raises(UsageError, match="weight slots take"):
        band_load(bluerov, -500.0)


@pytest.mark.slow
def test_the_band_holds_show_the_edges_of_the_trimmed_vehicles_vertical_thrusters(
        tmp_path: Path, bluerov: Profile) -> None:
    """The perturbed Heavy trimmed, its proposal fitted, then ``calibrate --band``: each
    load trimd chooses after the first hold makes the TRUE vehicle as heavy (then as
    buoyant) as it aims (within twice the first hold's ± of W − B), the hold with it
    shows the upper (then lower) edges of vertical thrusters, each where the simulated
    ESC's really is, both experiments are learnt, and the three recordings replay to
    them."""
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
    assert len(loads) == 2 and "upper band edges" in asked[0], asked
    assert "lower band edges" in asked[1] and "take " in asked[1], asked
    T = thrust_configuration(bluerov.thrusters)
    lifting = [i for i in range(len(bluerov.thrusters)) if abs(T[2, i]) >= LIFTING]
    true_offsets = trial.vehicle.offset.band_offsets_us
    known = np.sqrt(done.experiments[0].q_before_cov[0, 0])   # the first hold's ± on W − B
    for exp, load, upward in zip(done.experiments, loads, (True, False), strict=True):
        aimed = band_margin_N(bluerov, upward) * (1 if upward else -1)
        true_w_minus_b = trial.vehicle.ballasted(f"{extra}{carried(load)}").net[0]
        assert abs(true_w_minus_b - aimed) <= 2 * known, (true_w_minus_b, aimed, known)
        shown = [o for o in edges_of([exp], bluerov) if o.thruster in lifting
                 and o.positive == ((T[2, o.thruster] < 0) == upward)]
        assert len({o.thruster for o in shown}) >= 2, (upward, shown)
        for o in shown:
            assert abs(o.offset_us - true_offsets[o.thruster][int(o.positive)]) <= 1.0, o
    assert all(o.accepted for o in done.outcomes), [o.message for o in done.outcomes]
    again = asyncio.run(replay_calibration([str(tmp_path / f"hold{k}.tlog")
                                            for k in (0, 1, 2)], None))
    assert [o.message for o in again.outcomes] == [o.message for o in done.outcomes]


def test_trimd_calibrate_band_says_what_to_hang_and_checks_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``trimd calibrate --band --yes --json`` on a served simulator nobody hangs anything
    on: after the first hold it says what to hang and where for the upper edges, then
    what to swap it for for the lower ones; the second hold, which sees none of the
    first load, is rejected as the load never put on, stored so, exit 1. (The swap
    between the two loads is some 30 g, within the third hold's noise: its experiment
    cannot tell.)"""
    code = main(["calibrate", "--link", "sim:seed=4,truth=perturbed", "--profile",
                 "bluerov2-heavy", "--band", "--yes", "--json", "--no-record", "--hold-s",
                 "30", "--db", str(tmp_path / "trimd.db")])
    out, err = capsys.readouterr()
    done = json.loads(out)
    assert code == 1 and not done["accepted"], (out, err)
    assert ("upper band edges it should be heavy at +0.13 N (its W − B is known to ± 0.48 N "
            "only") in err
    assert "the load may miss it" in err and "): hang 0.147 kg" in err and "W-amid-ctr" in err
    assert "lower band edges it should be buoyant at -0.16 N" in err, err
    assert "take 0.147 kg (its weight in water) at slot W-mid-ctr and 0.246 kg" in err, err
    first, _ = done["experiments_run"]
    assert not first["accepted"] and "W-amid-ctr" in first["label"], first
    assert "the known weight" in first["message"], first["message"]
    with History(tmp_path / "trimd.db") as h:
        stored = [r.values["accepted"] for r in h.experiments("bluerov2-heavy")]
    assert len(stored) == 2 and stored[0] is False, stored
