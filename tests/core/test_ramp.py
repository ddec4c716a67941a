"""The ramp of the commanded roll and pitch to each hold (trimd/core/ramp.py)."""

from __future__ import annotations

import dataclasses
import math
from itertools import pairwise

import numpy as np
import pytest

from tests.core.test_procedure import run
from tests.helpers import FakeVehicle, command_plan, payload_truth, sim_trim
from trimd.app.report import NewCommands
from trimd.core.events import Phase
from trimd.core.procedure import Procedure
from trimd.core.profile import Profile
from trimd.core.ramp import TiltRamp
from trimd.core.samples import HoldAttitude, Release

#: The small-payload BlueROV2 Heavy of the coverage bench, and a seed whose step from
#: level to 20°/20° overshot past the 30° envelope.
SMALL_PAYLOAD, OVERSHOT_SEED = "0.48@0.08,-0.1,0.06", 39


def test_the_ramp_moves_each_axis_at_its_rate_from_where_the_command_was() -> None:
    rate, tol = math.radians(5.0), math.radians(1.0)
    ramp = TiltRamp(rate, tol)
    assert ramp.toward(10.0, (0.0, 0.0), (0.9 * tol, -0.9 * tol)) == (0.0, 0.0)  # near: at once
    assert not ramp.advance(10.1)                                      # there: no new command
    ramp = TiltRamp(rate, tol)
    assert ramp.toward(10.0, (0.0, 0.0), (0.0, -2 * tol)) == (0.0, -2 * tol)  # the vehicle's
    assert ramp.advance(10.2) and ramp.command == pytest.approx((0.0, -2 * tol + 0.2 * rate))
    assert ramp.advance(11.0) and ramp.command == (0.0, 0.0)
    target = (math.radians(20.0), math.radians(-4.0))
    assert ramp.toward(20.0, target, (0.3, 0.3)) == (0.0, 0.0)        # from the command
    assert ramp.advance(21.0)
    assert ramp.command == pytest.approx((rate, -math.radians(4.0)))  # pitch there, roll on
    assert ramp.advance(30.0) and ramp.command == target
    assert not ramp.advance(31.0)


def test_a_hold_is_commanded_at_no_more_than_the_tilt_rate(sabertooth: Profile) -> None:
    """From level to the 20°/20° hold the command moves at ``tilt_rate_deg_s``, never
    beyond the hold, and the hold settles and collects once the command is there."""
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    vehicle = FakeVehicle(sabertooth, W, r_g)
    proc = Procedure(sabertooth, confirmed=True)
    run(proc, vehicle, 1000.0)
    assert proc.phase is Phase.DONE, proc.reason
    assert command_plan([c for _, c in vehicle.commands]) == [(0.0, 0.0), (20.0, 20.0),
                                                              "release"]
    held = [(t, c) for t, c in vehicle.commands if isinstance(c, HoldAttitude)]
    rate = sabertooth.procedure.tilt_rate_deg_s
    for (t0, a), (t1, b) in pairwise(held):
        for x, y in ((a.phi, b.phi), (a.theta, b.theta)):
            assert abs(math.degrees(y - x)) <= rate * (t1 - t0) + 1e-9
            assert -1e-9 <= math.degrees(y) <= 20.0 + 1e-9
    reached = next(t for t, c in held if round(math.degrees(c.phi), 6) == 20.0)
    assert reached - held[0][0] >= 20.0 / rate
    assert proc.estimate is not None and proc.estimate.holds[1].t_start_s >= reached


@pytest.mark.parametrize(("rate_deg_s", "done"), [(5.0, True), (1000.0, False)])
def test_the_ramp_keeps_a_dead_band_vehicle_inside_its_envelope(bluerov: Profile,
                                                                 rate_deg_s: float,
                                                                 done: bool) -> None:
    """On the simulated small-payload Heavy (thrusters idle in their dead band) a step
    from level to 20°/20° overshoots past the 30° envelope and the trim stops safely; the
    ramp at the profile's 5°/s takes it there and the trim ends."""
    profile = dataclasses.replace(bluerov, procedure=dataclasses.replace(
        bluerov.procedure, tilt_rate_deg_s=rate_deg_s))
    trial = sim_trim(profile, SMALL_PAYLOAD, OVERSHOT_SEED, "disturb=real,truth=perturbed")
    if done:
        assert trial.result.phase is Phase.DONE, trial.result.reason
    else:
        assert trial.result.phase is Phase.FAILED
        assert "attitude out of envelope" in trial.result.reason


def test_the_presenters_show_a_ramp_once_not_its_steps() -> None:
    """The event log and headless output show a hold's command, not each step of its ramp
    or of the heading leash: those are in the session log."""
    new = NewCommands()
    ramp = [HoldAttitude(math.radians(d), math.radians(d), 0.1 * d)
            for d in np.arange(0.0, 20.1, 0.3)]
    shown = [text for text in map(new, ramp) if text is not None]
    assert shown == ["hold roll 0.0°, pitch 0.0°, yaw 0.0°"]
    assert new(HoldAttitude(0.0, 0.0, 0.0)) is not None   # a jump back to level is news
    assert new(Release()) == "release control"
    assert new(HoldAttitude(0.0, 0.0, 0.0)) is not None   # a hold after a release is news
