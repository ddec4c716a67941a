"""The built-in simulated vehicle: Fossen 6-DOF physics, thrusters, controller, sensors.

Modules, one job each: :mod:`~drivers.sim.payload` (hidden payload → true mass
properties), :mod:`~drivers.sim.dynamics` (equations of motion, RK4),
:mod:`~drivers.sim.thrusters` (mixing, PWM, spin-up, thrust curves),
:mod:`~drivers.sim.controller` (MANUAL / STABILIZE / ALT_HOLD),
:mod:`~drivers.sim.sensors` (noise, gyro bias, DVL, current), :mod:`~drivers.sim.config`
(options and the ``sim:`` URL syntax), :mod:`~drivers.sim.vehicle` (all of it stepped
together; the API every server uses), :mod:`~drivers.sim.link` (in-process Link) and
:mod:`~drivers.sim.mavlink_server` (served as an ArduSub vehicle over MAVLink).
See ``docs/simulator.md``.
"""

from drivers.sim.config import SimConfig, parse_sim_options
from drivers.sim.link import SimLink, open_sim_link
from drivers.sim.vehicle import SimVehicle, Truth

__all__ = ["SimConfig", "SimLink", "SimVehicle", "Truth", "open_sim_link",
           "parse_sim_options"]
