"""Options of the simulated vehicle and their ``sim:`` URL syntax.

``sim:KEY=VALUE,KEY=VALUE,…`` where each KEY is a field of :class:`SimConfig` (SI units, as
the field name says). Booleans are ``1/0``, ``true/false``, ``yes/no``. A payload body
position contains commas (``payload=3.5@0.2,-0.1,0.05``): a comma-separated piece without
``=`` continues the previous value. Examples::

    sim
    sim:payload=10@AftSB
    sim:payload=0.4@W-aft-ctr,seed=3,current_m_s=0.05
    sim:payload=3.5@0.2,-0.1,0.05,noise=0,dvl=1
"""

from __future__ import annotations

import dataclasses
import difflib
from dataclasses import dataclass
from typing import Any

from trimd.core.errors import LinkError

__all__ = ["SimConfig", "parse_sim_options"]


@dataclass(frozen=True, slots=True)
class SimConfig:
    """Everything configurable about the simulated vehicle (SI units).

    Attributes
    ----------
    payload : hidden payload (``trimd.drivers.sim.payload``), e.g. ``10@AftSB``.
    seed : seed of every random draw (noise, gyro bias, current phases).
    dt_s : integration and controller step [s] (RK4; 0.01 = 100 Hz).
    depth_m, heading_rad : start depth [m] and heading [rad]; the vehicle starts level at
        rest.
    armed, mode : start armed, in this ArduSub mode (MANUAL, STABILIZE, ALT_HOLD).
    station : hold horizontal position too (a position fix); otherwise a hold keeps depth
        but not station and the vehicle drifts at a tilt.
    dvl : the vehicle reports its body velocity (Velocity samples).
    damping : hydrodynamic damping on (off only for energy tests).
    thruster_lag_s : first-order spin-up time constant of each thruster [s].
    voltage_V : battery voltage [V]; 0 means the profile's nominal voltage.
    noise : factor on every sensor noise level below (0 = perfect sensors).
    attitude_noise_rad, rate_noise_rad_s, gyro_bias_rad_s, depth_noise_m,
    depth_rate_noise_m_s, dvl_noise_m_s : sensor noise standard deviations (the gyro bias
        is drawn once per seed with this standard deviation).
    current_m_s : mean speed of the slowly varying horizontal water current [m/s].
    attitude_bandwidth_rad_s, depth_bandwidth_rad_s : controller bandwidths [rad/s].
    attitude_hz, thrusters_hz, depth_hz, velocity_hz, battery_hz, health_hz : sample
        rates of the in-process link [Hz of simulated time].
    """

    payload: str = ""
    seed: int = 0
    dt_s: float = 0.01
    depth_m: float = 5.0
    heading_rad: float = 0.0
    armed: bool = True
    mode: str = "ALT_HOLD"
    station: bool = False
    dvl: bool = False
    damping: bool = True
    thruster_lag_s: float = 0.1
    voltage_V: float = 0.0
    noise: float = 1.0
    attitude_noise_rad: float = 0.001
    rate_noise_rad_s: float = 0.002
    gyro_bias_rad_s: float = 0.001
    depth_noise_m: float = 0.003
    depth_rate_noise_m_s: float = 0.005
    dvl_noise_m_s: float = 0.003
    current_m_s: float = 0.0
    attitude_bandwidth_rad_s: float = 2.0
    depth_bandwidth_rad_s: float = 1.0
    attitude_hz: float = 20.0
    thrusters_hz: float = 10.0
    depth_hz: float = 5.0
    velocity_hz: float = 5.0
    battery_hz: float = 1.0
    health_hz: float = 1.0


_FIELDS = {f.name: f for f in dataclasses.fields(SimConfig)}
_TRUE, _FALSE = ("1", "true", "yes", "on"), ("0", "false", "no", "off")


def parse_sim_options(text: str, base: SimConfig | None = None) -> SimConfig:
    """The :class:`SimConfig` of a ``sim:`` URL's options (module docstring).

    Raises
    ------
    LinkError
        For an unknown key (naming the nearest one) or a value of the wrong type.

    Examples
    --------
    >>> c = parse_sim_options("payload=3.5@0.2,-0.1,0.05,seed=3,dvl=1")
    >>> c.payload, c.seed, c.dvl
    ('3.5@0.2,-0.1,0.05', 3, True)
    """
    pairs: list[list[str]] = []
    for piece in filter(None, text.split(",")):
        if "=" in piece:
            key, _, value = piece.partition("=")
            pairs.append([key.strip(), value])
        elif pairs:
            pairs[-1][1] += "," + piece
        else:
            raise LinkError(f"sim option '{piece}': expected KEY=VALUE")
    values: dict[str, Any] = {}
    for key, value in pairs:
        if key not in _FIELDS:
            near = difflib.get_close_matches(key, _FIELDS, n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ""
            raise LinkError(f"unknown sim option '{key}'{hint}")
        values[key] = _convert(key, value.strip())
    return dataclasses.replace(base or SimConfig(), **values)


def _convert(key: str, value: str) -> Any:
    kind = _FIELDS[key].type
    try:
        if kind == "bool":
            if value.lower() not in _TRUE + _FALSE:
                raise ValueError(value)
            return value.lower() in _TRUE
        if kind == "int":
            return int(value)
        if kind == "float":
            return float(value)
    except ValueError:
        raise LinkError(f"sim option {key}={value}: expected a {kind}") from None
    return value
