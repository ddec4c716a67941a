"""Is the vehicle at rest in the water? The passive watch's gate, one sample at a time.

A vehicle in a stabilised mode cruises, turns and stops at one attitude (level), so its
attitude alone does not tell a transit from a stop. :class:`MotionGate` tells them apart
from what a link reports without the pilot's sticks:

* **transit** — the mean surge or sway effort over :data:`EFFORT_WINDOW_S` differs from
  what the restoring forces need at the present attitude by more than half the profile's
  net-buoyancy window (the force floor of the stop rule,
  :meth:`trimd.core.decision.StopRule.effort_floor`): a thruster pushing the vehicle
  along. A vehicle at rest in ALT_HOLD without a position fix puts no surge or sway
  effort out at all;
* **coasting** — after the thrusters stop, the vehicle glides on until drag has taken
  its speed. Without a DVL, the speed through the water comes from the transit's effort
  through the profile's surge and sway model, (m + m_A)·u̇ = X − d₁·u − d₂·|u|·u
  (Fossen's diagonal damping, :class:`SpeedObserver`; X the net force while it is beyond
  the force floor, 0 after), with the slowest decay the prior allows
  (:data:`HYDRO_SPREAD`: mass and added mass 50 % more, damping 50 % less, the spread of
  the unseen vehicles trimd is tested on); the vehicle counts as stopped once that speed
  is below :data:`MAX_SPEED_M_S`. The effort that drag explains while the vehicle
  coasts is no trim. Where a DVL reports (a Velocity sample within
  :data:`VELOCITY_AGE_S`), its mean horizontal speed over :data:`EFFORT_WINDOW_S` decides
  instead;
* **turning** — the heading's least-squares rate over the long window
  (:data:`trimd.core.settling.LONG_WINDOW_S`) of the stretch exceeds the procedure's
  ``rate_tol_deg_s``. Only the long window: the heading loop hunting about a held
  heading (±10–20° at a period of ≈ 10 s on the simulated BlueROV2 Heavy, whose
  thrusters idle in their dead band) moves the heading at 2–3°/s over 10 s but
  < 1°/s over 20 s. The window holds the samples since the stretch began (the gate
  last said moving), so the heading is judged once a stretch is that long — shorter
  than the settling test and a segment need together — and a turn in a stretch ends it
  there. A turn's yaw effort (its damping, tenths of a N·m on the Heavy) is smaller than
  that hunting's, so the heading, not the yaw effort, shows it.

The watch breaks its stretch wherever the gate says moving; each stop then goes through
the live settling test (:mod:`trimd.core.settling`) on its own. Time is the samples' own
[s]; forces [N], moments [N·m], speeds [m/s].
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from trimd.core.decision import StopRule
from trimd.core.model import restoring_matrix
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Velocity
from trimd.core.settling import LONG_WINDOW_S, RATE_WINDOW_S
from trimd.core.types import FloatArray

__all__ = ["COASTING", "EFFORT_WINDOW_S", "HYDRO_SPREAD", "MAX_SPEED_M_S", "MOVING_DVL",
           "TRANSIT", "TURNING", "VELOCITY_AGE_S", "MotionGate", "SpeedObserver"]


#: Largest horizontal speed of a vehicle at rest [m/s] (over ground by a DVL, through the
#: water by :class:`SpeedObserver`).
MAX_SPEED_M_S = 0.1
#: The surge and sway effort, and a DVL's speed, are judged by their mean over this
#: trailing window [s] (the settling test's rate window).
EFFORT_WINDOW_S = RATE_WINDOW_S
#: A DVL sample younger than this [s] makes the DVL, not the effort model, judge speed.
VELOCITY_AGE_S = 1.0
#: The share by which the profile's surge and sway mass (with added mass) may be too
#: small and its damping too large: the speed model decays by the slowest the prior
#: allows (the unseen-vehicle bench draws every parameter × U[0.5, 1.5]).
HYDRO_SPREAD = 0.5
#: A gap in the effort longer than this [s] restarts the speed model from rest.
MAX_EFFORT_GAP_S = 5.0

#: Why the gate says moving (the watch counts its breaks by these).
TRANSIT = "transit (surge or sway effort)"
COASTING = "coasting (speed from the effort)"
MOVING_DVL = "moving (DVL)"
TURNING = "turning (heading)"


class SpeedObserver:
    """Surge and sway speed through the water [m/s] from the net horizontal effort, with
    the profile's hydrodynamics at the slow end of the prior (:data:`HYDRO_SPREAD`).

    Each update is semi-implicit in the damping, so it is stable at any sample interval:
    u ← (u + dt·X/m) / (1 + dt·(d₁ + d₂·|u|)/m). ``None`` from :attr:`speed` when the
    profile has no damping on an axis (nothing would bring the model to rest)."""

    def __init__(self, profile: Profile) -> None:
        grow, shrink = 1 + HYDRO_SPREAD, 1 - HYDRO_SPREAD
        self._m = tuple(grow * (profile.mass_kg + profile.added_mass[i]) for i in (0, 1))
        self._d1 = tuple(shrink * abs(profile.linear_damping[i]) for i in (0, 1))
        self._d2 = tuple(shrink * abs(profile.quadratic_damping[i]) for i in (0, 1))
        self.damped = all(a + b > 0 for a, b in zip(self._d1, self._d2, strict=True))
        self.uv = [0.0, 0.0]
        self._t = math.nan

    def update(self, t_s: float, force_xy: tuple[float, float]) -> None:
        """The net surge and sway force [N] (effort less restoring) from ``t_s`` on."""
        dt = t_s - self._t
        self._t = t_s
        if not dt > 0:
            return
        if dt > MAX_EFFORT_GAP_S:
            self.uv = [0.0, 0.0]
            return
        for i in (0, 1):
            m, u = self._m[i], self.uv[i]
            self.uv[i] = (u + dt * force_xy[i] / m) / (
                1 + dt * (self._d1[i] + self._d2[i] * abs(u)) / m)

    @property
    def speed(self) -> float | None:
        return math.hypot(*self.uv) if self.damped else None


class MotionGate:
    """Feed the effort, velocity and attitude samples in time order; :meth:`why_moving`
    says why the vehicle is not at rest now (None: it is).

    ``q_prior`` [N, N·m] (the baseline or the nominal vehicle) gives the restoring
    forces the surge and sway effort is compared with."""

    def __init__(self, profile: Profile, q_prior: FloatArray) -> None:
        self.q_prior = np.asarray(q_prior, float)
        self.force_floor = StopRule.for_profile(profile).buoyancy_half_window_N
        self.rate_tol = math.radians(profile.procedure.rate_tol_deg_s)
        self.observer = SpeedObserver(profile)
        self._phi = self._theta = 0.0
        self._effort: deque[tuple[float, ...]] = deque()
        self._velocity: deque[tuple[float, ...]] = deque()
        self._heading: deque[tuple[float, ...]] = deque()

    def effort(self, t_s: float, tau: FloatArray) -> None:
        """τ [N, N·m] of one thruster sample. The speed model is driven by the net force
        of an axis only while its mean is beyond the force floor (a transit); below it,
        what is left is what the trim does not explain (the prior's restoring forces at a
        tilt, the thrust map), and the model coasts on drag alone."""
        g = restoring_matrix(self._phi, self._theta)[:2] @ self.q_prior
        net = (float(tau[0] - g[0]), float(tau[1] - g[1]))
        _push(self._effort, (t_s, *net), t_s - EFFORT_WINDOW_S)
        mean = np.mean([e[1:] for e in self._effort], axis=0)
        pushing = np.abs(mean) > self.force_floor
        self.observer.update(t_s, (net[0] if pushing[0] else 0.0,
                                   net[1] if pushing[1] else 0.0))

    def velocity(self, v: Velocity) -> None:
        _push(self._velocity, (v.t_s, math.hypot(v.u, v.v)), v.t_s - EFFORT_WINDOW_S)

    def attitude(self, a: Attitude) -> None:
        self._phi, self._theta = a.phi, a.theta
        psi = a.psi
        if self._heading:   # unwrapped, so a turn through ±180° is one line
            last = self._heading[-1][1]
            psi = last + math.remainder(psi - last, math.tau)
        _push(self._heading, (a.t_s, psi), a.t_s - LONG_WINDOW_S)

    def why_moving(self, t_s: float) -> str | None:
        """Why the vehicle is not at rest at ``t_s`` [s] (module docstring), or None;
        when moving, the stretch ends: the heading window starts again."""
        why = self._why(t_s)
        if why is not None:
            self._heading.clear()
        return why

    def _why(self, t_s: float) -> str | None:
        effort = [e for e in self._effort if e[0] >= t_s - EFFORT_WINDOW_S]
        if effort:
            mean = np.mean([e[1:] for e in effort], axis=0)
            if float(np.max(np.abs(mean))) > self.force_floor:
                return TRANSIT
        dvl = [v for t, v in self._velocity if t >= t_s - EFFORT_WINDOW_S]
        if dvl and t_s - self._velocity[-1][0] <= VELOCITY_AGE_S:
            if float(np.mean(dvl)) > MAX_SPEED_M_S:
                return MOVING_DVL
        else:
            speed = self.observer.speed
            if speed is not None and speed > MAX_SPEED_M_S:
                return COASTING
        return TURNING if self._turning(t_s) else None

    def _turning(self, t_s: float) -> bool:
        """The heading's rate over the long window of the stretch (module docstring)."""
        h = np.array(self._heading)
        if len(h) < 3 or t_s - h[0, 0] < 0.9 * LONG_WINDOW_S:
            return False
        return abs(_slope(h)) > self.rate_tol


def _push(window: deque[tuple[float, ...]], item: tuple[float, ...], oldest: float) -> None:
    window.append(item)
    while window[0][0] < oldest:
        window.popleft()


def _slope(tx: FloatArray) -> float:
    """Least-squares slope of column 1 over column 0."""
    t = tx[:, 0] - tx[:, 0].mean()
    tt = float(t @ t)
    return float(t @ (tx[:, 1] - tx[:, 1].mean()) / tt) if tt > 0 else 0.0
