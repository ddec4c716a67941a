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
           "TRANSIT", "TURNING", "VELOCITY_AGE_S", "MotionGate", "SpeedObserver", "Window"]


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
        self._effort = Window(2)
        self._velocity = Window(1)
        self._heading = Window(1)

    def effort(self, t_s: float, tau: FloatArray) -> None:
        """τ [N, N·m] of one thruster sample. The speed model is driven by the net force
        of an axis only while its mean is beyond the force floor (a transit); below it,
        what is left is what the trim does not explain (the prior's restoring forces at a
        tilt, the thrust map), and the model coasts on drag alone."""
        g = restoring_matrix(self._phi, self._theta)[:2] @ self.q_prior
        net = (float(tau[0] - g[0]), float(tau[1] - g[1]))
        self._effort.push((t_s, *net), t_s - EFFORT_WINDOW_S)
        mean_x, mean_y = self._effort.mean()
        self.observer.update(t_s, (net[0] if abs(mean_x) > self.force_floor else 0.0,
                                   net[1] if abs(mean_y) > self.force_floor else 0.0))

    def velocity(self, v: Velocity) -> None:
        self._velocity.push((v.t_s, math.hypot(v.u, v.v)), v.t_s - EFFORT_WINDOW_S)

    def attitude(self, a: Attitude) -> None:
        self._phi, self._theta = a.phi, a.theta
        psi = a.psi
        if self._heading.items:   # unwrapped, so a turn through ±180° is one line
            last = self._heading.items[-1][1]
            psi = last + math.remainder(psi - last, math.tau)
        self._heading.push((a.t_s, psi), a.t_s - LONG_WINDOW_S)

    def why_moving(self, t_s: float) -> str | None:
        """Why the vehicle is not at rest at ``t_s`` [s] (module docstring), or None;
        when moving, the stretch ends: the heading window starts again."""
        why = self._why(t_s)
        if why is not None:
            self._heading.clear()
        return why

    def _why(self, t_s: float) -> str | None:
        mean = self._effort.mean(since=t_s - EFFORT_WINDOW_S)
        if mean and max(abs(m) for m in mean) > self.force_floor:
            return TRANSIT
        dvl = self._velocity.mean(since=t_s - EFFORT_WINDOW_S)
        if dvl and t_s - self._velocity.items[-1][0] <= VELOCITY_AGE_S:
            if dvl[0] > MAX_SPEED_M_S:
                return MOVING_DVL
        else:
            speed = self.observer.speed
            if speed is not None and speed > MAX_SPEED_M_S:
                return COASTING
        return TURNING if self._turning(t_s) else None

    def _turning(self, t_s: float) -> bool:
        """The heading's rate over the long window of the stretch (module docstring)."""
        h = self._heading
        if len(h.items) < 3 or t_s - h.items[0][0] < 0.9 * LONG_WINDOW_S:
            return False
        return abs(h.slope()) > self.rate_tol


class Window:
    """Samples (t, x₁ … x_k) of a trailing time window [s] with their running sums, so
    that each sample costs the same however long the window: the mean of each x and the
    least-squares slope of x₁ over t. The sums are taken about the first sample since the
    window (re)started and are summed afresh once as many samples have left as it holds,
    so rounding does not build up."""

    def __init__(self, k: int) -> None:
        self.items: deque[tuple[float, ...]] = deque()
        self._k = k
        self._restart()

    def _restart(self) -> None:
        first = self.items[0] if self.items else (0.0,) * (self._k + 1)
        self._origin = first
        self._n = self._left = 0
        self._sums = [0.0] * self._k          # Σx
        self._st = self._stt = self._stx = 0.0  # Σt, Σt², Σt·x₁
        for item in self.items:
            self._add(item, 1)

    def _add(self, item: tuple[float, ...], sign: int) -> None:
        t0, *x0 = self._origin
        t = item[0] - t0
        self._n += sign
        for i in range(self._k):
            self._sums[i] += sign * (item[i + 1] - x0[i])
        self._st += sign * t
        self._stt += sign * t * t
        self._stx += sign * t * (item[1] - x0[0])

    def push(self, item: tuple[float, ...], oldest: float) -> None:
        """Add ``item`` (t first) and drop the samples older than ``oldest`` [s]."""
        if not self.items:
            self.items.append(item)
            self._restart()
        else:
            self.items.append(item)
            self._add(item, 1)
        finite = True
        while self.items[0][0] < oldest:
            gone = self.items.popleft()
            self._add(gone, -1)
            self._left += 1
            finite = finite and all(map(math.isfinite, gone))
        if self._left >= len(self.items) or not finite:
            self._restart()     # a NaN that left stays in the sums until summed afresh

    def clear(self) -> None:
        self.items.clear()
        self._restart()

    def mean(self, since: float = -math.inf) -> tuple[float, ...]:
        """The mean of each x over the samples from ``since`` [s] on (empty: none)."""
        n, sums = self._n, list(self._sums)
        _, *x0 = self._origin
        for item in self.items:     # the oldest, already out of a later window
            if item[0] >= since:
                break
            n -= 1
            for i in range(self._k):
                sums[i] -= item[i + 1] - x0[i]
        return tuple(x0[i] + sums[i] / n for i in range(self._k)) if n > 0 else ()

    def slope(self) -> float:
        """The least-squares slope of x₁ over t [unit/s] (0 when t does not vary)."""
        n = self._n
        tt = self._stt - self._st * self._st / n
        return (self._stx - self._st * self._sums[0] / n) / tt if tt > 0 else 0.0
