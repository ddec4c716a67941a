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
    """The load aims W − B at the margin, at slots whose x and y moments cancel: weights
    for a buoyant vehicle, floats' lift for one heavier than the margin."""
    for profile, w_minus_b in ((bluerov, -1.3), (bluerov, 2.0), (sabertooth, -8.0)):
        load = band_load(profile, w_minus_b)
        forces = np.array([f for _, f in load.pieces])
        where = np.array([profile.slot(s).position_m for s, _ in load.pieces])
        assert forces.sum() == pytest.approx(band_margin_N(profile) - w_minus_b)
        assert np.all(np.sign(forces) == np.sign(forces.sum()))
        assert np.allclose(forces @ where[:, :2], 0.0, atol=1e-9)
        assert load.moment_Nm == pytest.approx((0.0, 0.0), abs=1e-9)
    with pytest.raises(UsageError, match="weight slots take"):
        band_load(bluerov, -500.0)


@pytest.mark.slow
def test_the_band_hold_shows_the_upper_edges_of_the_trimmed_vehicles_vertical_thrusters(
        tmp_path: Path, bluerov: Profile) -> None:
    """The perturbed Heavy trimmed, its proposal fitted, then ``calibrate --band``: the
    load trimd chooses after the first hold makes the TRUE vehicle as heavy as it aims
    (within twice the first hold's ± of W − B), the second hold shows the upper edges of
    vertical thrusters, each where the simulated ESC's really is, the experiment is learnt,
    and the two recordings replay to it."""
    trial = sim_trim(bluerov, PAYLOAD, SEED, OPTIONS)
    proposal = trial.result.proposal
    assert isinstance(proposal, Proposal), trial.result.reason
    extra = ballast_payload(proposal, bluerov)
    loads: list[Load] = []

    def carried_load() -> str:
        return "".join(f"+{w.kg:.6f}@{','.join(map(str, bluerov.slot(w.slot).position_m))}"
                       for load in loads for w in load)

    def opener() -> Awaitable[Link]:
        return open_link(f"sim:payload={PAYLOAD}+{extra}{carried_load()},"
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
    assert len(loads) == 1 and "upper band edges" in asked[0], asked
    [exp] = done.experiments
    aimed = band_margin_N(bluerov)
    true_after = trial.vehicle.ballasted(f"{extra}{carried_load()}").net[0]
    assert abs(true_after - aimed) <= 2 * np.sqrt(exp.q_before_cov[0, 0]), (true_after, aimed)
    T = thrust_configuration(bluerov.thrusters)
    lifting = [i for i in range(len(bluerov.thrusters)) if abs(T[2, i]) >= LIFTING]
    true_offsets = trial.vehicle.offset.band_offsets_us
    upper = [o for o in edges_of([exp], bluerov)
             if o.thruster in lifting and o.positive == (T[2, o.thruster] < 0)]
    assert len({o.thruster for o in upper}) >= 2, upper
    for o in upper:
        assert abs(o.offset_us - true_offsets[o.thruster][int(o.positive)]) <= 1.0, o
    assert done.outcomes[0].accepted, done.outcomes[0].message
    again = asyncio.run(replay_calibration([str(tmp_path / f"hold{k}.tlog") for k in (0, 1)],
                                           None))
    assert [o.message for o in again.outcomes] == [o.message for o in done.outcomes]


def test_trimd_calibrate_band_says_what_to_hang_and_checks_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``trimd calibrate --band --yes --json`` on a served simulator nobody hangs anything
    on: it says what to hang and where after the first hold, and the second hold, which
    sees no change, is rejected as the load never put on, stored so, exit 1."""
    code = main(["calibrate", "--link", "sim:seed=4,truth=perturbed", "--profile",
                 "bluerov2-heavy", "--band", "--yes", "--json", "--no-record", "--hold-s",
                 "30", "--db", str(tmp_path / "trimd.db")])
    out, err = capsys.readouterr()
    done = json.loads(out)
    assert code == 1 and not done["accepted"], (out, err)
    assert "upper band edges it should be +0.13 N (its W − B is known to ± 0.48 N only" in err
    assert "the load may miss it" in err and "): hang 0.147 kg" in err and "W-amid-ctr" in err
    [exp] = done["experiments_run"]
    assert not exp["accepted"] and "W-amid-ctr" in exp["label"], exp
    assert "the known weight" in exp["message"], exp["message"]
    with History(tmp_path / "trimd.db") as h:
        assert [r.values["accepted"] for r in h.experiments("bluerov2-heavy")] == [False]
