"""The built-in simulated vehicle: Fossen 6-DOF physics, thrusters, controller, sensors.

Modules, one job each: :mod:`~trimd.drivers.sim.payload` (hidden payload → true mass
properties), :mod:`~trimd.drivers.sim.dynamics` (equations of motion, RK4),
:mod:`~trimd.drivers.sim.thrusters` (mixing, PWM, spin-up, thrust curves),
:mod:`~trimd.drivers.sim.controller` (MANUAL / STABILIZE / ALT_HOLD),
:mod:`~trimd.drivers.sim.sensors` (noise, gyro bias, DVL, current),
:mod:`~trimd.drivers.sim.disturbance` (slow Gauss–Markov disturbances),
:mod:`~trimd.drivers.sim.truth` (a vehicle that differs from its profile; passive trim),
:mod:`~trimd.drivers.sim.config` (options, presets and the ``sim:`` URL syntax),
:mod:`~trimd.drivers.sim.vehicle` (all of it stepped together; the API every server uses),
:mod:`~trimd.drivers.sim.link` (in-process Link) and
:mod:`~trimd.drivers.sim.mavlink_server` (served as an ArduSub vehicle over MAVLink).
See ``docs/simulator.md``.
"""

from trimd.drivers.sim.config import SimConfig, parse_sim_options, with_presets
from trimd.drivers.sim.link import SimLink, open_sim_link
from trimd.drivers.sim.vehicle import SimVehicle, Truth

__all__ = ["SimConfig", "SimLink", "SimVehicle", "Truth", "open_sim_link",
           "parse_sim_options", "with_presets"]
