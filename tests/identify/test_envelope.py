"""An excitation keeps its envelope: the excitation is halved as the vehicle goes further,
stops early (done, every sample kept, said so) before the guard would abort it, and an
unseen vehicle whose buoyancy and hydrodynamics differ from the prior completes its
experiment inside the default envelope."""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.identify.test_excitation import _ready
from trimd.app.experiment import run_experiment
from trimd.core.events import Notice, Phase
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Depth, OpenLoop, Release, Thrusters
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle
from trimd.identify.envelope import ADAPT_SHARES, SCALE_STEP, STOP_EARLY, STOP_SHARES, Envelope
from trimd.identify.experiment import STREAM_HZ, Excite
from trimd.identify.signals import design_signal
from trimd.identify.vehicles import perturbed


def test_the_excitation_is_halved_at_each_share_and_stops_beyond_the_last() -> None:
    env = Envelope(5.0, math.radians(30.0))
    first = ADAPT_SHARES["depth"][0]
    assert env.depth(0.6 * 5.0) is None and env.scale == 1.0
    step = env.depth(-(first + 0.01) * 5.0)
    assert step is not None and not step.stop and env.scale == SCALE_STEP
    assert env.depth(first * 5.0 + 0.1) is None                 # the same share: once
    # a tilt that comes back scales nothing until close to its limit
    assert env.tilt(0.0, math.radians(-0.8 * 30.0)) is None
    step = env.tilt(0.0, math.radians(-0.9 * 30.0))             # tilt counts on its own
    assert step is not None and env.scale == SCALE_STEP**2 and "pitch -27.0°" in step.text
    step = env.depth((STOP_SHARES["depth"] + 0.01) * 5.0)
    assert step is not None and step.stop and "91 % of the ±5 m envelope" in step.text
    assert env.depth_range_m == (pytest.approx(-3.3), pytest.approx(4.55))
    assert "tilt at most 27.0°" in env.summary()


def test_excite_scales_its_inputs_then_stops_early_and_releases(sabertooth: Profile) -> None:
    """Past half the depth envelope every input's deviation from its trim offset halves;
    past STOP_SHARE the experiment releases the vehicle and ends done, saying that it
    stopped early and where."""
    sig = design_signal(sabertooth, "uvr", duration_s=60.0, seed=0)
    e = Excite(sabertooth, sig, confirmed=True, depth_excursion_m=5.0)
    started = [o.t_s for o in _ready(e) if isinstance(o, Notice) and o.phase is Phase.COLLECT]
    assert e.phase is Phase.COLLECT
    pwm = tuple(1500.0 for _ in sabertooth.thrusters)
    sent: list[np.ndarray] = []

    def command(t: float, *events: object) -> list[object]:
        """The outputs of ``events`` and two thruster samples at ``t`` (commands are paced
        by them); a new command goes to ``sent``."""
        out: list[object] = []
        for ev in (*events, Thrusters(t - 0.05, pwm), Thrusters(t, pwm)):
            out += e.step(ev)   # type: ignore[arg-type]
        sent.extend(np.asarray(o.axes) for o in out if isinstance(o, OpenLoop))
        return out

    offsets = np.asarray(sig.offsets)
    sel = [d.axis for d in sig.axes]
    t = 6.5   # after the samples _ready sent (up to 5.98 s)
    out = command(t, Depth(t - 0.1, 10.0 + (ADAPT_SHARES["depth"][0] + 0.05) * 5.0))
    assert [o for o in out if isinstance(o, Notice) and "scaled to 50 %" in o.text]
    # the excited axes' deviation from the trim halves (the depth hold, not scaled, moves
    # heave)
    np.testing.assert_allclose(sent[-1][sel] - offsets[sel], SCALE_STEP * (
        np.asarray(sig.at(t - started[0]))[sel] - offsets[sel]), atol=1e-9)
    out = e.step(Depth(t + 0.1, 10.0 + 0.95 * 5.0))
    assert isinstance(out[0], Release) and e.phase is Phase.DONE
    assert e.reason.startswith(f"{STOP_EARLY} at ") and "95 % of the ±5 m envelope" in e.reason
    assert e.step(Attitude(t + 0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)) == []


def _unseen_sabertooth(prior: Profile) -> Profile:
    """Vehicle 2 of the unseen-vehicle bench (hydrodynamics × U[0.5, 1.5]) with 0.78 % more
    buoyancy than the prior: 91 N up. With the heave doublets about the prior's trim alone
    its uwq stage rose out of a 5 m envelope after ≈ 80 s."""
    truth = perturbed(prior, np.random.default_rng(1002), name="unseen")
    return dataclasses.replace(truth, buoyancy_N=truth.buoyancy_N * 1.0078)


def test_an_unseen_vehicle_completes_uwq_inside_the_default_envelope(
        sabertooth: Profile) -> None:
    truth = _unseen_sabertooth(sabertooth)
    sig = design_signal(sabertooth, "uwq", duration_s=120.0, seed=22, depth_excursion_m=5.0)
    assert sig.depth_hold is not None
    vehicle = SimVehicle(truth, SimConfig(seed=22, depth_m=100.0, attitude_hz=STREAM_HZ,
                                          thrusters_hz=STREAM_HZ, depth_hz=STREAM_HZ))
    excite = Excite(sabertooth, sig, confirmed=True, depth_excursion_m=5.0, stage="uwq")
    result, samples = asyncio.run(run_experiment(SimLink(vehicle), sabertooth, excite))
    assert result.phase is Phase.DONE and result.reason.startswith("excitation complete")
    depth = np.array([s.depth_m for s in samples if isinstance(s, Depth)]) - 100.0
    assert np.abs(depth).max() < 0.5 * 5.0 and "excitation at 100 %" in result.reason


@pytest.mark.slow
def test_an_experiment_stopped_early_is_identified_and_said_so(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """In a 0.3 m envelope the Sabertooth's uwq stage stops early; its recording names the
    stop, and ``trimd identify`` fits it and says that it stopped early."""
    from trimd.cli.main import main

    log = tmp_path / "uwq.tlog"
    assert main(["excite", "--link", "sim", "--profile", "sabertooth-dh2", "--stage", "uwq",
                 "--max-depth-excursion", "0.3", "--duration", "120", "--yes",
                 "--record", str(log)]) == 0
    err = capsys.readouterr().err
    assert f"trimd: {STOP_EARLY} at " in err
    code = main(["identify", str(log), "--profile", "sabertooth-dh2", "--json"])
    out, err = capsys.readouterr()
    result = json.loads(out.strip().splitlines()[-1])
    assert code == 0 and result["type"] == "identification"
    assert result["stopped_early"][str(log)].startswith(STOP_EARLY)
    assert "±0.3 m envelope" in result["stopped_early"][str(log)]
    assert f"{log}: {STOP_EARLY}" in err
    fitted = result["stages"]["uwq"]["parameters"]
    assert fitted["Z_wdot"]["free"] and fitted["M_q"]["free"]
