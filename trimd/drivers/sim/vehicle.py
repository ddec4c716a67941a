"""The simulated vehicle: dynamics, thrusters, controller and sensors stepped together.

:class:`SimVehicle` is the one API that every way of exposing the simulator uses (the
in-process link, the MAVLink server, a serial server): commands go in as method calls,
telemetry comes out as ``trimd.core.samples`` values, and tests read :attr:`SimVehicle.truth`.
Time is simulated: nothing here reads a clock.

The vehicle flies :attr:`SimVehicle.true_profile` (the profile itself, unless the config
perturbs it: :mod:`trimd.drivers.sim.truth`); its mixer and controller, like trimd, know only
the nominal profile.

One step of ``dt`` (default 10 ms): the slow disturbances advance, the sensors read the
state, the controller (when armed) turns the reading into axis inputs, the mixer into
integer PWM (plus dither), the thrusters into τ through their curves and spin-up lag, and
RK4 advances the state with τ and the water current held over the step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trimd.core.model import restoring_forces
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Battery, Depth, Health, Sample, Thrusters, Velocity
from trimd.core.types import FloatArray
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.controller import MODE_CLASSES, MODES, Controller
from trimd.drivers.sim.disturbance import Disturbances
from trimd.drivers.sim.dynamics import RigidBody, euler_from_quaternion, initial_state
from trimd.drivers.sim.payload import MassProperties, PayloadItem, mass_properties, parse_payload
from trimd.drivers.sim.scenario import Scenario
from trimd.drivers.sim.sensors import Reading, Sensors
from trimd.drivers.sim.thrusters import Mixer, ThrusterBank
from trimd.drivers.sim.truth import implied_mass, passive_trim_deg, perturb_profile
from trimd.drivers.sim.wander import torque_std_for_wander

__all__ = ["SAMPLE_KINDS", "SimVehicle", "Truth"]


#: What :meth:`SimVehicle.sample` can produce.
SAMPLE_KINDS = ("attitude", "thrusters", "depth", "velocity", "battery", "health")


@dataclass(frozen=True)
class Truth:
    """The simulator's hidden truth at one instant (never shown to the estimator).

    Attributes
    ----------
    t_s : simulated time [s].
    eta : [n, e, d, φ, θ, ψ] [m, rad] (NED, ZYX Euler).
    nu : [u, v, w, p, q, r] [m/s, rad/s] (body FRD).
    tau : generalised force of the thrusters [N, N·m] (body FRD), after spin-up lag.
    g_eta : restoring forces g(η) at the true attitude [N, N·m] (Fossen eq. 4.6).
    mass : true mass properties (W, B, r_g, r_b; ``mass.net`` = q of docs/method.md §3),
        of the true profile when the config perturbs it.
    payload : the hidden payload items.
    m_ext_kg : added mass of the weights [kg] (floats not included).
    """

    t_s: float
    eta: FloatArray
    nu: FloatArray
    tau: FloatArray
    g_eta: FloatArray
    mass: MassProperties
    payload: tuple[PayloadItem, ...]
    m_ext_kg: float


class SimVehicle:
    """A simulated vehicle described by ``profile``, with the options of ``config``.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> v = SimVehicle(load_profile("sabertooth-dh2"), SimConfig(payload="10@AftSB"))
    >>> v.run_for(1.0)
    >>> round(v.t_s, 6), v.truth.m_ext_kg, len(v.pwm_us)
    (1.0, 10.0, 6)

    Attributes
    ----------
    profile : the nominal profile (what trimd, the mixer and the controller read).
    true_profile : the profile the physics flies (buoyancy, r_b and thrust curves off by
        ``offset`` when the config perturbs them).
    offset : how ``true_profile`` differs from ``profile``.
    disturbances : the slow disturbances (their present values).
    """

    def __init__(self, profile: Profile, config: SimConfig | None = None) -> None:
        c = config or SimConfig()
        if c.mode not in MODES:
            raise ValueError(f"simulated mode must be one of {MODES}, got {c.mode!r}")
        self.profile = profile
        self.config = c
        self.true_profile, self.offset = perturb_profile(profile, c)
        self.payload = self._own_payload = parse_payload(c.payload, profile)
        self.scenario = Scenario(profile, c.leak_N_min, c.leak_start_s, c.leak_at, c.drop,
                                 c.pilot, c.leak_max_N)
        self._steps_per_s = max(1, round(1.0 / c.dt_s))
        self.mass = mass_properties(self.true_profile, self.payload)
        self.body = RigidBody(self.true_profile, self.mass, damping=c.damping)
        self.voltage_V = c.voltage_V or profile.nominal_voltage_V
        self.mixer = Mixer(profile, self.voltage_V)
        self.thrusters = ThrusterBank(self.true_profile, self.voltage_V, c.thruster_lag_s,
                                      hunt=c.esc_hunt)
        self.controller = Controller(profile, self.mixer, c.dt_s, station=c.station,
                                     attitude_bandwidth=c.attitude_bandwidth_rad_s,
                                     depth_bandwidth=c.depth_bandwidth_rad_s)
        self.disturbances = Disturbances(c, len(profile.thrusters), self._torque_std())
        self.sensors = Sensors(c, self.disturbances)
        self.dt_s = c.dt_s
        self.steps = 0
        self.x = initial_state(c.depth_m, psi=c.heading_rad)
        self.armed = c.armed
        self.mode = c.mode
        self.pwm_us: tuple[int, ...] = self.mixer.neutral()
        self.tau: tuple[float, ...] = (0.0,) * 6
        self.reading: Reading = self.sensors.read(0.0, self.x)
        self.controller.reset(self.reading)

    def _torque_std(self) -> tuple[float, float]:
        """Roll and pitch disturbance torques [N·m, 1σ] that leave the configured
        ``torque_wander_deg`` through the attitude loop (:mod:`trimd.drivers.sim.wander`)."""
        c, p = self.config, self.true_profile
        if not c.torque_wander_deg:
            return (0.0, 0.0)
        stiffness = float(self.mass.net[3])
        std = []
        for axis in (0, 1):
            kp, ki, kd = self.controller.gains(axis)
            std.append(torque_std_for_wander(
                math.radians(c.torque_wander_deg), c.torque_wander_tau_s,
                p.inertia_kg_m2[axis] + p.added_mass[3 + axis], -p.linear_damping[3 + axis],
                stiffness, kp, ki, kd))
        return (std[0], std[1])

    @property
    def t_s(self) -> float:
        """Simulated time [s]."""
        return self.steps * self.dt_s

    # ------------------------------------------------------------------ stepping
    def step(self) -> None:
        """Advance one step of ``dt_s``."""
        t, dt, x, sensors = self.steps * self.dt_s, self.dt_s, self.x, self.sensors
        d = self.disturbances
        if d.active:
            d.step()
            self.controller.setpoint_offset = d.setpoint_rad
        scenario = self.scenario
        if scenario.changes_mass and self.steps % self._steps_per_s == 0:
            self._change_payload(self._own_payload + scenario.payload(t))
        sticks = scenario.sticks(t)
        if sticks is not None:
            self.controller.pilot = sticks
        self.reading = reading = sensors.read(t, x)
        if self.armed:
            mixer = self.mixer
            self.pwm_us = mixer.pwm(mixer.outputs(self.controller.update(reading, self.mode)),
                                    d.dither_us)
        self.tau = tau = self.thrusters.step(self.pwm_us, dt)
        dK, dM = d.torque_Nm
        if dK or dM:
            tau = (tau[0], tau[1], tau[2], tau[3] + dK, tau[4] + dM, tau[5])
        self.x = self.body.rk4(x, tau, sensors.current(t), dt)
        self.steps += 1

    def _change_payload(self, payload: tuple[PayloadItem, ...]) -> None:
        """Fly with ``payload`` from now on (the state is kept)."""
        if payload != self.payload:
            self.payload = payload
            self.mass = mass_properties(self.true_profile, payload)
            self.body = RigidBody(self.true_profile, self.mass, damping=self.config.damping)

    def run_for(self, duration_s: float) -> None:
        """Advance by ``duration_s`` [s] of simulated time (whole steps)."""
        for _ in range(round(duration_s / self.dt_s)):
            self.step()

    # ------------------------------------------------------------------ commands
    def arm(self, armed: bool) -> None:
        """Arm (the controller starts from the present attitude, depth and heading) or
        disarm (thrusters to neutral)."""
        if armed and not self.armed:
            self.controller.reset(self.reading)
        if not armed:
            self.pwm_us = self.mixer.neutral()
        self.armed = armed

    def set_mode(self, mode: str) -> None:
        """Fly ``mode`` (MANUAL, STABILIZE or ALT_HOLD); ValueError for any other."""
        if mode not in MODES:
            raise ValueError(f"the simulated vehicle flies {', '.join(MODES)}, not {mode}")
        if mode != self.mode:
            self.controller.reset(self.reading)
            self.controller.open_loop = None
        self.mode = mode

    def hold_attitude(self, phi: float, theta: float, psi: float) -> None:
        """Hold roll, pitch, yaw [rad] (STABILIZE / ALT_HOLD; depth hold continues)."""
        self.controller.set_target(phi, theta, psi)

    def level(self) -> None:
        """Back to the pilot's neutral: level, keeping the held heading and depth."""
        self.controller.set_target(0.0, 0.0, self.controller.target[2])

    def pilot(self, forward: float, lateral: float, throttle: float, yaw: float) -> None:
        """Pilot sticks in [−1, 1]: surge, sway, throttle (up positive), yaw rate."""
        f, lat, thr, y = (max(-1.0, min(1.0, float(s))) for s in (forward, lateral, throttle, yaw))
        self.controller.pilot = (f, lat, thr, y)

    def open_loop(self, axes: Sequence[float]) -> None:
        """Open-loop axis inputs in [−1, 1] (surge, sway, heave down, roll, pitch, yaw):
        switches to MANUAL."""
        if len(axes) != 6:
            raise ValueError(f"open-loop input has 6 axes, got {len(axes)}")
        self.set_mode("MANUAL")
        self.controller.open_loop = tuple(max(-1.0, min(1.0, float(a))) for a in axes)

    # ------------------------------------------------------------------ telemetry
    def sample(self, kind: str) -> Sample:
        """The latest ``kind`` sample (one of :data:`SAMPLE_KINDS`), stamped with the time
        of the reading it comes from on the vehicle's clock (``SimConfig.clock_jump_s``)."""
        r = self.reading
        c = self.config
        t = r.t_s + c.clock_jump_s if c.clock_jump_s and r.t_s >= c.clock_jump_at_s else r.t_s
        if kind == "attitude":
            return Attitude(t, r.phi, r.theta, r.psi, r.p, r.q, r.r)
        if kind == "thrusters":
            return Thrusters(t, tuple(float(p) for p in self.thrusters.reported_us))
        if kind == "depth":
            return Depth(t, r.depth_m)
        if kind == "velocity":
            return Velocity(t, r.u, r.v, r.w)
        if kind == "battery":
            return Battery(t, self.voltage_V)
        if kind == "health":
            return Health(t, True, self.mode, self.armed,
                          vehicle=f"simulated {self.profile.name}",
                          mode_class=MODE_CLASSES[self.mode])
        raise ValueError(f"unknown sample kind {kind!r} (known: {', '.join(SAMPLE_KINDS)})")

    @property
    def truth(self) -> Truth:
        """The true state, thrust and mass properties now."""
        phi, theta, psi = euler_from_quaternion(*self.x[3:7])
        m = self.mass
        return Truth(
            t_s=self.t_s, eta=np.array([*self.x[:3], phi, theta, psi]),
            nu=np.array(self.x[7:13]), tau=np.array(self.tau),
            g_eta=restoring_forces(phi, theta, m.W, m.B, m.r_g, m.r_b), mass=m,
            payload=self.payload,
            m_ext_kg=sum(p.mass_kg for p in self.payload if p.mass_kg > 0))

    def ballasted(self, extra_payload: str) -> MassProperties:
        """True mass properties with ``extra_payload`` (payload syntax, e.g. a ballast
        proposal's pieces) added to the hidden payload: with :func:`passive_trim_deg` of
        its ``net``, where the true vehicle would float after ballasting.

        Raises
        ------
        ProfileError
            For a malformed item or a slot the profile does not have.
        """
        extra = parse_payload(extra_payload, self.profile)
        return mass_properties(self.true_profile, self.payload + extra)

    def describe_truth(self) -> str:
        """The hidden payload and what a perfect estimate would find, for people."""
        m = self.mass
        items = ", ".join(p.label for p in self.payload) or "none"
        r_g = ", ".join(f"{1000 * v:+.1f}" for v in m.r_g)
        net = self.mass.net
        roll, pitch = passive_trim_deg(net)
        text = (f"simulator truth: payload {items}; m_ext {self.truth.m_ext_kg:.3f} kg, "
                f"W − B {net[0]:+.2f} N, r_g ({r_g}) mm, "
                f"W·r_g − B·r_b ({', '.join(f'{v:+.3f}' for v in net[1:])}) N·m; "
                f"passive trim roll {roll:+.2f}°, pitch {pitch:+.2f}°")
        if self.true_profile is self.profile:
            return text
        o = self.offset
        c = self.config
        thrust = f"{100 * c.thrust_err:g}" + (f"–{100 * c.thrust_err_max:g}"
                                             if c.thrust_err_max > c.thrust_err else "")
        m_ext, r_g_seen = implied_mass(self.profile, net)
        return (f"{text}; the vehicle is off its profile (B ×{o.buoyancy_factor:.3f}, r_b "
                f"{', '.join(f'{1000 * v:+.1f}' for v in o.r_b_offset_m)} mm, thrust "
                f"±{thrust} %): an exact estimate reads m_ext "
                f"{m_ext:.3f} kg, r_g ({', '.join(f'{1000 * v:+.1f}' for v in r_g_seen)}) mm")
