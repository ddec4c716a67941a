"""Flight controller of the simulated vehicle: ArduSub-like MANUAL, STABILIZE and ALT_HOLD.

* MANUAL: the axis inputs (pilot sticks, or an open-loop excitation) go to the mixer as
  they are.
* STABILIZE: PID attitude hold on the attitude error quaternion (roll, pitch and absolute
  yaw); surge, sway and throttle from the pilot.
* ALT_HOLD: STABILIZE plus PID depth hold. Without a position sensor the horizontal
  thrusters get only the pilot's surge and sway, so at a tilted hold the vehicle holds
  depth but not station and drifts, as a real ArduSub vehicle does (docs/method.md §3); with
  ``station=True`` (a position fix) a PID on north/east holds station as well.

Every PID has integral action, bounded by the axis's authority and frozen while the axis
is saturated (anti-windup). Gains come from the profile's nominal inertia plus added mass
J and a bandwidth ω: a triple pole at −ω, Kp = 3ω²J, Kd = 3ωJ, Ki = ω³J. The controller
sees only sensor readings and the nominal profile, never the true payload.
"""

from __future__ import annotations

import math

from trimd.core.model import quaternion_from_euler
from trimd.core.profile import Profile
from trimd.core.samples import ModeClass
from trimd.drivers.sim.sensors import Reading
from trimd.drivers.sim.thrusters import Mixer

__all__ = ["MODES", "MODE_CLASSES", "Controller"]

#: Modes the simulated vehicle flies (ArduSub names).
MODES = ("MANUAL", "STABILIZE", "ALT_HOLD")
#: What each of them does, as its Health samples say (ArduSub's classes).
MODE_CLASSES = {"MANUAL": ModeClass.MANUAL, "STABILIZE": ModeClass.STABILISED,
                "ALT_HOLD": ModeClass.DEPTH_HOLDING}

_CLIMB_M_S = 0.5      # depth-target rate at full pilot throttle [m/s]
_YAW_RATE = 0.8       # heading-target rate at full pilot yaw [rad/s]
_STICK_DEADZONE = 0.05
#: axis input (X, Y, Z, K, M, N index) driven by each integrator slot: K, M, N, depth,
#: north, east
_SLOT_AXES = (3, 4, 5, 2, 0, 1)


def _gains(J: float, omega: float) -> tuple[float, float, float]:
    """(Kp, Ki, Kd) of a PID with a triple closed-loop pole at −ω for inertia J."""
    return 3 * omega ** 2 * J, omega ** 3 * J, 3 * omega * J


class Controller:
    """Attitude, depth and (optional) station hold for one vehicle.

    Parameters
    ----------
    profile : nominal vehicle (inertia, added mass) for the gains.
    mixer : gives each axis's authority ``tau_unit`` [N, N·m per unit input].
    dt : controller period [s].
    station : hold horizontal position too (needs a position fix).
    attitude_bandwidth, depth_bandwidth : closed-loop bandwidths ω [rad/s].
    """

    def __init__(self, profile: Profile, mixer: Mixer, dt: float, *, station: bool = False,
                 attitude_bandwidth: float = 1.2, depth_bandwidth: float = 0.8) -> None:
        self.dt = dt
        self.station = station
        self._unit = tuple(float(u) for u in mixer.tau_unit)
        m = profile.mass_kg
        J = [i + a for i, a in zip(profile.inertia_kg_m2, profile.added_mass[3:], strict=True)]
        gains = [*(_gains(j, attitude_bandwidth) for j in J),
                 _gains(m + profile.added_mass[2], depth_bandwidth),
                 *(_gains(m + a, 0.5 * depth_bandwidth) for a in profile.added_mass[:2])]
        #: per integrator slot: (Kp, Ki, Kd, integral limit, axis input it drives); the
        #: integral is bounded by the axis's authority: |Ki·∫e| ≤ |tau_unit|
        self._pids = tuple((kp, ki, kd, abs(self._unit[axis]) / ki, axis)
                           for (kp, ki, kd), axis in zip(gains, _SLOT_AXES, strict=True))
        self.target = (0.0, 0.0, 0.0)
        self._q_t = quaternion_from_euler(0.0, 0.0, 0.0)
        self.depth_target = 0.0
        self.position_target = (0.0, 0.0)
        self.pilot = (0.0, 0.0, 0.0, 0.0)
        self.open_loop: tuple[float, ...] | None = None
        #: wander added to the held roll and pitch [rad] (``SimConfig.attitude_wander_deg``)
        self.setpoint_offset: tuple[float, ...] = (0.0, 0.0)
        self._i = [0.0] * 6          # integrals: K, M, N, depth, north, east
        self._saturated = [False] * 6

    def reset(self, reading: Reading) -> None:
        """Start holding the present heading level, the present depth and position, with
        empty integrators (on arming or a mode change)."""
        self.set_target(0.0, 0.0, reading.psi)
        self.depth_target = reading.depth_m
        self.position_target = (reading.north_m, reading.east_m)
        self._i = [0.0] * 6
        self._saturated = [False] * 6

    def gains(self, axis: int) -> tuple[float, float, float]:
        """(Kp, Ki, Kd) of the attitude PID of ``axis`` (0 roll, 1 pitch, 2 yaw) [N·m per
        rad, rad·s, rad/s]."""
        kp, ki, kd, _, _ = self._pids[axis]
        return kp, ki, kd

    def set_target(self, phi: float, theta: float, psi: float) -> None:
        """Attitude to hold: roll, pitch, yaw [rad]."""
        self.target = (phi, theta, psi)
        self._q_t = quaternion_from_euler(phi, theta, psi)

    def update(self, reading: Reading, mode: str) -> tuple[float, ...]:
        """Axis inputs (X, Y, Z, K, M, N, normalised) for one controller period."""
        fwd, lat, thr, yaw = [0.0 if abs(s) < _STICK_DEADZONE else s for s in self.pilot]
        if mode == "MANUAL":
            return self.open_loop or (fwd, lat, -thr, 0.0, 0.0, yaw)
        dt = self.dt
        if yaw:
            self.set_target(self.target[0], self.target[1], self.target[2] + yaw * _YAW_RATE * dt)
        # attitude error as a rotation vector in the body frame: q_e = q_m* ⊗ q_t
        a0, a1, a2, a3 = quaternion_from_euler(reading.phi, reading.theta, reading.psi)
        d_phi, d_theta = self.setpoint_offset
        if d_phi or d_theta:
            phi_t, theta_t, psi_t = self.target
            b0, b1, b2, b3 = quaternion_from_euler(phi_t + d_phi, theta_t + d_theta, psi_t)
        else:
            b0, b1, b2, b3 = self._q_t
        w = a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
        s = 2.0 if w >= 0 else -2.0
        pid = self._pid
        K = pid(0, s * (a0 * b1 - a1 * b0 - a2 * b3 + a3 * b2), reading.p)
        M = pid(1, s * (a0 * b2 + a1 * b3 - a2 * b0 - a3 * b1), reading.q)
        N = pid(2, s * (a0 * b3 - a1 * b2 + a2 * b1 - a3 * b0), reading.r)
        uX, uY, uZ, uK, uM, uN = self._unit
        X, Y = fwd * uX, lat * uY
        if mode == "ALT_HOLD":
            if thr:
                self.depth_target -= thr * _CLIMB_M_S * dt
            F_d = pid(3, self.depth_target - reading.depth_m, reading.depth_rate_m_s)
            if self.station:
                X, Y, Z = self._station(reading, a0, a1, a2, a3, F_d)
            else:
                Z = F_d / max(0.5, math.cos(reading.phi) * math.cos(reading.theta))
        else:
            Z = -thr * uZ
        axes = (X / uX, Y / uY, Z / uZ, K / uK, M / uM, N / uN)
        self._saturated = [abs(a) >= 1.0 for a in axes]
        return axes

    def _pid(self, slot: int, error: float, rate: float) -> float:
        """Kp·e + Ki·∫e − Kd·ė with integrator ``slot`` (its axis input saturated: the
        integral holds while the error would grow it further)."""
        kp, ki, kd, limit, axis = self._pids[slot]
        i = self._i[slot]
        if not (self._saturated[axis] and i * error > 0):
            i += error * self.dt
            i = limit if i > limit else -limit if i < -limit else i
            self._i[slot] = i
        return kp * error + ki * i - kd * rate

    def _station(self, reading: Reading, q0: float, q1: float, q2: float, q3: float,
                 F_d: float) -> tuple[float, float, float]:
        """Body force (X, Y, Z) [N] holding position north/east and depth (F_d, world)."""
        R = ((1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)),
             (2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)),
             (2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)))
        body_v = (reading.u, reading.v, reading.w)
        world_v = [sum(R[i][j] * body_v[j] for j in range(3)) for i in range(2)]
        F_n = self._pid(4, self.position_target[0] - reading.north_m, world_v[0])
        F_e = self._pid(5, self.position_target[1] - reading.east_m, world_v[1])
        F = (F_n, F_e, F_d)
        return (sum(R[i][0] * F[i] for i in range(3)), sum(R[i][1] * F[i] for i in range(3)),
                sum(R[i][2] * F[i] for i in range(3)))
