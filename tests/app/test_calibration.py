"""The thrust map learns (issue 24): known ballast changes between level holds of the
simulated BlueROV2 Heavy whose thrust curves are 5 % off its profile (``truth=perturbed``)
are calibration experiments. Physics, not shapes: the posterior gains must move toward the
TRUE curves' errors and cover them, a later trim's ± must shrink and still cover the TRUE
vehicle, and a piece heavier than its inventory entry must be caught, not learnt.
"""

from __future__ import annotations

import asyncio
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import sim_level_hold, sim_trim
from trimd.app.connect import open_link
from trimd.app.session import Session
from trimd.core.calibration import (
    REJECT_P,
    Calibration,
    Experiment,
    PieceChange,
    ballast_change,
    calibrate,
    calibration_hold,
    posterior,
    update,
)
from trimd.core.errors import EstimationError
from trimd.core.estimate import StaticEstimate
from trimd.core.learnt import gains
from trimd.core.link import Link
from trimd.core.profile import Profile
from trimd.core.profile_yaml import read_profile_text
from trimd.core.segment import estimate_segment
from trimd.drivers.sim.config import SimConfig, with_presets
from trimd.drivers.sim.truth import perturb_profile, thrust_map_errors
from trimd.logs.recorder import TlogRecorder
from trimd.logs.replay import ReplayLink, with_recorded_thrust_map

OPTIONS = "disturb=real,truth=perturbed"
PAYLOAD = "0.4@W-aft-stbd"
#: The pieces fitted one step after another (each step one experiment).
STEPS = ((PieceChange("W-front-stbd", "lead-200g", 3),),
         (PieceChange("W-aft-port", "lead-200g", 3),))
#: A third step, checked against the first two.
THIRD = (PieceChange("W-aft-ctr", "lead-200g", 3), PieceChange("W-front-port", "lead-200g", 3))
Z95 = 1.96


def fitted(profile: Profile, steps: tuple[tuple[PieceChange, ...], ...], heavier: float = 1.0
           ) -> str:
    """The simulator's payload items of the pieces of ``steps`` (in-water mass at each slot;
    the last step's pieces ``heavier`` times what the inventory says)."""
    items = []
    for k, step in enumerate(steps):
        for c in step:
            piece, slot = profile.piece(c.piece), profile.slot(c.slot)
            kg = c.count * piece.net_down_N(profile.water_density_kg_m3, 1.0)
            kg *= heavier if k == len(steps) - 1 else 1.0
            items.append(f"{kg:.6f}@{','.join(str(v) for v in slot.position_m)}")
    return "+".join([PAYLOAD, *items])


def experiments(profile: Profile, seed: int, steps: tuple[tuple[PieceChange, ...], ...],
                heavier: float = 1.0) -> list[Experiment]:
    """A level hold before the first step and after each (the last step's pieces in the
    simulator ``heavier`` than the inventory says): one experiment per step, q before it
    from the first hold's level fit and the pieces fitted since."""
    holds = [sim_level_hold(profile, fitted(profile, steps[:k],
                                            heavier if k == len(steps) else 1), seed, OPTIONS)
             for k in range(len(steps) + 1)]
    q = estimate_segment(holds[0], profile).q
    q_cov = np.diag([0.1, 0.01, 0.01, 0.1])  # [N², N²·m²]: enters through G₂ − G₁ only
    out = []
    for k, step in enumerate(steps):
        after = q + ballast_change(profile, step)[0]
        out.append(Experiment(f"step {k + 1}", calibration_hold(holds[k], profile, q),
                              calibration_hold(holds[k + 1], profile, after), step, q, q_cov))
        q = after
    return out


def true_gain_errors(profile: Profile, seed: int) -> np.ndarray:
    """The simulated vehicle's relative gain errors, forward then reverse per thruster, in
    units of the profile's 1σ (``uncertainty_pct``)."""
    _, offset = perturb_profile(profile, with_presets(SimConfig(seed=seed), disturb="real",
                                                      truth="perturbed"))
    return thrust_map_errors(profile, offset)[:2 * len(profile.thrusters)]


@pytest.fixture(scope="module")
def learnt(bluerov: Profile) -> dict[int, Calibration]:
    return {seed: calibrate(experiments(bluerov, seed, STEPS), bluerov) for seed in (0, 2)}


@pytest.mark.parametrize("seed", [0, 2])
def test_the_posterior_gains_move_toward_the_true_curves(bluerov: Profile, seed: int,
                                                         learnt: dict[int, Calibration]
                                                         ) -> None:
    """Each experiment is consistent and learnt; the gains the data determine (the vertical
    thrusters' reverse thrust, which holds the buoyant Heavy down) move toward the TRUE
    curves' errors, the other gains keep the prior, and the truth lies within the
    posterior's 95 % interval."""
    cal = learnt[seed]
    assert all(o.accepted for o in cal.outcomes), [o.message for o in cal.outcomes]
    post, truth = cal.posterior, true_gain_errors(bluerov, seed)
    n = len(bluerov.thrusters)
    sd = np.sqrt(np.diag(post.cov))[:2 * n]
    determined = np.array([g.determined for g in gains(post, bluerov)])
    assert determined.sum() >= 2, sd
    assert {g.thruster for g, d in zip(gains(post, bluerov), determined, strict=True) if d
            } <= {"motor5", "motor6", "motor7", "motor8"}
    mean = post.mean[:2 * n]
    assert np.sqrt(np.mean((mean - truth)[determined] ** 2)) < np.sqrt(
        np.mean(truth[determined] ** 2)), (mean, truth)
    assert np.all(np.abs(mean - truth) <= Z95 * sd), (mean, truth, sd)
    assert np.allclose(sd[~determined], 1.0, atol=0.12)


def test_a_later_trim_is_narrower_and_still_covers_the_truth(bluerov: Profile,
                                                              learnt: dict[int, Calibration]
                                                              ) -> None:
    """A new trim of the same vehicle with another payload: with the calibration its ± of
    W − B and of every net moment is narrower than without, and the 95 % intervals still
    cover the TRUE vehicle."""
    seed = 0
    calibrated = replace(bluerov, thrust_map=learnt[seed].posterior)
    std = {}
    for name, profile in (("prior", bluerov), ("calibrated", calibrated)):
        trim = sim_trim(profile, "0.3@W-front-port", seed, OPTIONS)
        est = trim.result.estimate
        assert est is not None, trim.result.reason
        std[name] = np.sqrt(np.diag(est.q_cov))
        assert np.all(np.abs(est.q - trim.q_true) <= Z95 * std[name]), (name, est.q,
                                                                         trim.q_true)
    assert np.all(std["calibrated"] < 0.95 * std["prior"]), std


def test_a_piece_heavier_than_its_inventory_entry_is_rejected(bluerov: Profile,
                                                               learnt: dict[int, Calibration]
                                                               ) -> None:
    """After a good calibration, a third ballast change whose lead is 10 % heavier than
    the inventory says is rejected, saying which experiment, by how many σ and what to
    check, and the posterior stays as it was; the same change with the lead as stated is
    learnt."""
    seed = 0
    good = experiments(bluerov, seed, (*STEPS, THIRD))
    bad = experiments(bluerov, seed, (*STEPS, THIRD), heavier=1.1)
    accepted = calibrate(good, bluerov)
    assert all(o.accepted for o in accepted.outcomes), [o.message for o in accepted.outcomes]
    cal = calibrate(bad, bluerov)
    assert [o.accepted for o in cal.outcomes] == [True, True, False]
    rejected = cal.rejected[0]
    assert rejected.sigma > 3.3
    assert "'step 3'" in rejected.message and "rejected, not learnt" in rejected.message
    assert "lead-200g" in rejected.message and "W-aft-ctr" in rejected.message
    assert f"≈ {rejected.sigma:.1f}σ" in rejected.message
    # and how much more than the recorded lead the thrusters saw: 110 %, within its ±
    saw = re.search(r"the thrusters saw ([\d.]+)% ± ([\d.]+)%", rejected.message)
    assert saw and abs(float(saw[1]) - 110.0) <= 3 * float(saw[2]), rejected.message
    before = learnt[seed].posterior
    assert np.array_equal(cal.posterior.mean, before.mean)
    assert cal.posterior.experiments == 2


def test_a_piece_7_percent_heavier_is_caught_where_the_chi2_alone_would_learn_it(
        bluerov: Profile) -> None:
    """The same third change with the lead 7 % heavier than recorded: its χ² alone (14.1
    on 3 rows here) stays above the rejection's tail probability, but the thrusters saw
    107 % of what the recorded lead makes, > 3.3σ from 100 %: the check along the
    recorded change rejects it and says so."""
    from scipy.stats import chi2

    cal = calibrate(experiments(bluerov, 0, (*STEPS, THIRD), heavier=1.07), bluerov)
    assert [o.accepted for o in cal.outcomes] == [True, True, False]
    rejected = cal.rejected[0]
    assert chi2.sf(rejected.chi2, rejected.dof) > REJECT_P, rejected.chi2
    saw = re.search(r"the thrusters saw ([\d.]+)% ± ([\d.]+)%", rejected.message)
    assert saw and abs(float(saw[1]) - 107.0) <= 2 * float(saw[2]), rejected.message
    assert (float(saw[1]) - 100.0) / float(saw[2]) > 3.3, rejected.message


def test_a_change_recorded_as_pieces_that_cancel_is_still_checked(
        bluerov: Profile, learnt: dict[int, Calibration]) -> None:
    """Lead put on and the same lead taken off at one slot, recorded so, while three
    pieces really went on: the recorded change makes nothing, so there is no scale to
    test (no ratio in the message, no division by zero), and the χ² alone rejects it."""
    step = experiments(bluerov, 0, STEPS)[0]
    cancel = (PieceChange("W-front-stbd", "lead-200g", 3),
              PieceChange("W-front-stbd", "lead-200g", -3))
    post, outcome = update(learnt[0].posterior, replace(step, change=cancel), bluerov)
    assert not outcome.accepted and post.experiments == learnt[0].posterior.experiments
    assert "thrusters saw" not in outcome.message and "rejected, not learnt" in outcome.message


def test_a_calibrated_trim_replays_to_its_result(tmp_path: Path, bluerov: Profile,
                                                  learnt: dict[int, Calibration]) -> None:
    """The recording of a trim with a calibration carries it: replayed with the profile
    alone and the recorded calibration it gives bit for bit what the calibrated profile
    gives on the same recording (a recording quantises the samples, so not the in-process
    session's own numbers), and without the calibration it would not."""
    calibrated = replace(bluerov, thrust_map=learnt[0].posterior)
    log = tmp_path / "calibrated.tlog"

    async def session(link: Link, profile: Profile, recorder: TlogRecorder | None
                      ) -> StaticEstimate:
        # live: confirmed up front; a replay: where the recording says it was
        try:
            result = await Session(link, profile, recorder=recorder, presenters=[],
                                   confirmed=recorder is not None, wall_clock=False).run()
        finally:
            await link.close()
        assert result.estimate is not None, result.reason
        return result.estimate

    async def live() -> None:
        link = await open_link(f"sim:payload={PAYLOAD},seed=0,{OPTIONS}", calibrated)
        await session(link, calibrated,
                      TlogRecorder(log, calibrated, read_profile_text("bluerov2-heavy")[0]))

    asyncio.run(live())
    recorded = asyncio.run(session(ReplayLink(log, calibrated), calibrated, None))
    profile = with_recorded_thrust_map(log, bluerov)
    assert profile.thrust_map is not None
    replayed = asyncio.run(session(ReplayLink(log, profile), profile, None))
    assert np.array_equal(replayed.q, recorded.q) and np.array_equal(replayed.q_cov,
                                                                    recorded.q_cov)
    plain = asyncio.run(session(ReplayLink(log, bluerov), bluerov, None))
    assert not np.array_equal(plain.q_cov, recorded.q_cov)


def test_a_posterior_that_is_no_covariance_is_an_error_not_a_hang() -> None:
    """The Cholesky's jitter stops at the covariance's own scale: a non-finite or negative
    definite P is named, never looped on."""
    for cov in (np.full((4, 4), np.nan), -np.eye(4)):
        with pytest.raises(EstimationError, match="not a covariance"):
            posterior(np.zeros(4), cov, 1)
    assert np.allclose(posterior(np.zeros(2), np.diag([4.0, 0.0]), 1).sqrt_cov[0, 0], 2.0)
