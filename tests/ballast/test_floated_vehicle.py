"""The vehicle as a float check found it (:func:`trimd.ballast.correct.floated_vehicle`):
the float's two equations update the trim's prediction, so that an error the trim's
moments share with its stiffness (a thrust curve's gain) is corrected in the stiffness too."""

from __future__ import annotations

import math

import numpy as np

from trimd.ballast.check import SlotLoad
from trimd.ballast.correct import floated_vehicle
from trimd.core.floating import FloatResult
from trimd.core.profile import Profile
from trimd.core.static_estimate import StaticEstimate, net_estimate
from trimd.drivers.sim.truth import passive_trim_deg

#: The true vehicle [W − B, W·r_g − B·r_b] [N, N·m]: the Sabertooth's size, floating at
#: about −1.1° roll and 2.1° pitch.
TRUE_Q = np.array([-110.0, -18.6, -9.5, 502.0])
#: The ballast installed since the trim: 200 N in water 1 m forward and 0.5 m to starboard
#: (its moment 200, 100, 0 N·m), so that before it the vehicle was TRUE_Q less that.
LOAD = SlotLoad("bow", (1.0, 0.5, 0.0), weight_kg=22.0, float_kg=0.0, mass_kg=22.0,
                buoyancy_N=22.0 * 9.81 - 200.0, net_down_N=200.0)
BEFORE_Q = TRUE_Q - np.array([200.0, 200.0, 100.0, 0.0])
#: 1σ [fraction] of the thrust curves' common gain and [N, N·m] of what else the trim
#: does not know
GAIN_STD, OTHER_STD = 0.07, np.array([5.0, 0.3, 0.3, 4.0])


def float_at(roll_deg: float, pitch_deg: float, std_deg: float = 0.05) -> FloatResult:
    """A float check that found the vehicle at ``roll_deg``, ``pitch_deg`` ± ``std_deg``."""
    return FloatResult(roll_deg, pitch_deg, std_deg, std_deg, (std_deg, std_deg), (0.0, 0.0),
                       (0.0, 0.0), 300, 0.0, 60.0, 20.0, 0.0, 0.0, 0.25)


def trim_with_gain(profile: Profile, gain: float) -> StaticEstimate:
    """A trim of the vehicle before :data:`LOAD` whose every moment is ``gain`` times the
    truth's (one thrust gain error), with a covariance that says so: the gain's variance
    along the moments, plus the rest."""
    along = np.r_[0.0, BEFORE_Q[1:]]
    cov = GAIN_STD**2 * np.outer(along, along) + np.diag(OTHER_STD**2)
    return net_estimate(np.r_[BEFORE_Q[0], gain * BEFORE_Q[1:]], cov, profile, holds=(),
                        dofs_used=("Z", "K", "M"), residual_rms=np.full(6, np.nan))


def test_a_float_corrects_the_stiffness_that_shares_the_moments_error(
        sabertooth: Profile) -> None:
    """The trim's moments, stiffness W·z_g − B·z_b included, 8 % high (one gain), then a
    known ballast change: the float of the true vehicle puts the x/y net moments right
    and, through their shared error, the stiffness nearer the truth than the trim had it,
    its ± narrower (the known change is a calibration of the gain)."""
    trim = trim_with_gain(sabertooth, 1.08)
    roll, pitch = passive_trim_deg(TRUE_Q)
    vehicle = floated_vehicle(float_at(roll, pitch), trim, (LOAD,), sabertooth)
    before, after = trim.q[3] - TRUE_Q[3], vehicle.q[3] - TRUE_Q[3]
    assert abs(after) < 0.3 * abs(before), (before, after)
    assert math.sqrt(vehicle.q_cov[3, 3]) < 0.5 * math.sqrt(trim.q_cov[3, 3])
    assert np.allclose(vehicle.q[1:3], TRUE_Q[1:3], rtol=0.02), vehicle.q
    assert np.allclose(passive_trim_deg(vehicle.q), (roll, pitch), atol=0.01)
    assert "as predicted" in vehicle.notes[0] and "NOT" not in vehicle.notes[0]


def test_without_a_shared_error_the_stiffness_stays_the_trims(sabertooth: Profile) -> None:
    """A trim that knows W·z_g − B·z_b apart from the moments (no covariance between them)
    keeps it: the float moves the x/y net moments alone, to −m_z·tan θ / cos φ and
    m_z·tan φ."""
    cov = np.diag(np.r_[OTHER_STD[0], 3.0, 3.0, OTHER_STD[3]] ** 2)
    trim = net_estimate(TRUE_Q, cov, sabertooth, holds=(), dofs_used=("Z", "K", "M"),
                        residual_rms=np.full(6, np.nan))
    roll, pitch = 0.8, -1.5
    vehicle = floated_vehicle(float_at(roll, pitch), trim, (), sabertooth)
    assert vehicle.q[3] == trim.q[3] and vehicle.q[0] == trim.q[0]
    phi, theta = math.radians(roll), math.radians(pitch)
    expected = (-TRUE_Q[3] * math.tan(theta) / math.cos(phi), TRUE_Q[3] * math.tan(phi))
    assert np.allclose(vehicle.q[1:3], expected, rtol=0.02), (vehicle.q, expected)


def test_a_float_that_contradicts_the_trim_leaves_the_prediction_out(
        sabertooth: Profile) -> None:
    """A float 6° from where the trim (± about 0.3°) says the vehicle floats: the
    prediction's errors are not what its covariance says, so the x/y net moments are the
    float's alone with the prediction's stiffness, and the notes say NOT as predicted."""
    trim = trim_with_gain(sabertooth, 1.0)
    roll, pitch = passive_trim_deg(TRUE_Q)
    vehicle = floated_vehicle(float_at(roll + 6.0, pitch), trim, (LOAD,), sabertooth)
    assert vehicle.q[3] == trim.q[3]
    assert np.allclose(passive_trim_deg(vehicle.q), (roll + 6.0, pitch), atol=1e-6)
    assert "NOT as predicted" in vehicle.notes[0]
