"""Options of the simulated vehicle and their ``sim:`` URL syntax.

``sim:KEY=VALUE,KEY=VALUE,…`` where each KEY is a field of :class:`SimConfig` (SI units, as
the field name says). Booleans are ``1/0``, ``true/false``, ``yes/no``. A payload body
position contains commas (``payload=3.5@0.2,-0.1,0.05``): a comma-separated piece without
``=`` continues the previous value. Examples::

    sim
    sim:payload=10@AftSB
    sim:payload=0.4@W-aft-ctr,seed=3,current_m_s=0.05
    sim:payload=3.5@0.2,-0.1,0.05,noise=0,dvl=1
    sim:payload=0.4@W-aft-ctr,disturb=real,truth=perturbed,seed=7
    sim:disturb=real,ahrs_wander_deg=0.2
    sim:pilot=dive,leak_N_min=0.5,leak_start_s=300
    sim:pilot=dive,drop=lead-200g@W-aft-ctr@600

Two preset keys set several fields at once, before the other keys whatever their order (so
a key can change one field of a preset): ``disturb=real`` (:data:`DISTURB_REAL`, the slow
disturbances of a real vehicle; ``disturb=none``, the default, has none) and
``truth=perturbed`` (:data:`TRUTH_PERTURBED`, a vehicle that differs from its profile;
``truth=profile``, the default, is the profile exactly). In Python:
:func:`with_presets`.
"""

from __future__ import annotations

import dataclasses
import difflib
from dataclasses import dataclass
from typing import Any

from trimd.core.errors import LinkError

__all__ = ["DISTURB_REAL", "PRESETS", "TRUTH_PERTURBED", "SimConfig", "parse_sim_options",
           "with_presets"]


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
    noise : factor on every white sensor noise level below (0 = perfect sensors; the slow
        disturbances further down are not scaled).
    attitude_noise_rad, rate_noise_rad_s, gyro_bias_rad_s, depth_noise_m,
    depth_rate_noise_m_s, dvl_noise_m_s : sensor noise standard deviations (the gyro bias
        is drawn once per seed with this standard deviation).
    current_m_s : mean speed of the slowly varying horizontal water current [m/s].
    attitude_bandwidth_rad_s, depth_bandwidth_rad_s : controller bandwidths [rad/s].
    attitude_hz, thrusters_hz, depth_hz, velocity_hz, battery_hz, health_hz : sample
        rates of the in-process link [Hz of simulated time].

    Slow disturbances, each a first-order Gauss–Markov process
    (:mod:`trimd.drivers.sim.disturbance`) of the stated standard deviation and
    correlation time [s]; an amplitude of 0 (the default) switches it off:

    ahrs_wander_deg, ahrs_wander_tau_s : error of the AHRS roll and pitch estimate [deg]
        (each). The controller holds the estimate, so in a hold the true vehicle wanders
        and the reported attitude does not; at rest the reported attitude wanders.
    attitude_wander_deg, attitude_wander_tau_s : wander of the attitude the controller
        holds, roll and pitch [deg] (what disturbances and a loose attitude loop leave of a
        hold): true and reported attitude wander together.
    depth_wander_m, depth_wander_tau_s : error of the depth sensor [m] (pressure
        fluctuation, waves); depth hold follows it, so the vehicle heaves.
    current_wander_m_s, current_wander_tau_s : varying water current, north and east
        components [m/s] (each), added to the ``current_m_s`` one.
    gyro_wander_deg_s, gyro_wander_tau_s : varying gyro bias of p, q, r [deg/s] (each),
        added to the constant ``gyro_bias_rad_s`` one (bias instability).
    torque_wander_deg, torque_wander_tau_s : disturbance torques about roll and pitch
        (waves, tether, current on the frame), each a Gauss–Markov process sized so that
        the attitude loop leaves this RMS attitude wander [deg] (computed from the
        linearised loop, :func:`trimd.drivers.sim.wander.torque_std_for_wander`); the
        thrusters fight them, so effort wanders with them.
    thruster_dither_us, thruster_dither_tau_s : PWM dither of each thruster's output [µs]
        (ESC and controller jitter), before rounding to integer µs; reported PWM includes
        it.

    clock_jump_s, clock_jump_at_s : the vehicle's clock (the stamp of every sample; the
        physics is unaffected) jumps by ``clock_jump_s`` [s] (negative: back) once
        ``clock_jump_at_s`` [s] of simulated time have passed, as a time sync does. The
        in-process link and the serial server show it; the MAVLink server's
        time_boot_ms does not.

    A vehicle that differs from its profile (the simulator flies the truth; everything
    that reads the profile, the controller included, sees the nominal vehicle). The sign
    and direction of each error is drawn from ``truth_seed`` (its own random stream):

    truth_seed : seed of the vehicle's errors below; −1 (the default): ``seed``. Another
        ``seed`` with the same ``truth_seed`` is the same vehicle on another dive (other
        noise and disturbances), as a calibration and a later trim of one vehicle are.

    buoyancy_err : true buoyancy B = (1 ± buoyancy_err)·profile B [fraction].
    cob_err_mm : true centre of buoyancy r_b = profile r_b + cob_err_mm in a random
        direction [mm].
    thrust_err : each thruster's true thrust = (1 ± thrust_err)·profile curve, the sign
        drawn separately per thruster and per direction (forward, reverse) [fraction].
    thrust_err_max : when above ``thrust_err``, the size of each of those errors is drawn
        uniform in [thrust_err, thrust_err_max] (per thruster and direction, from a
        random stream of its own, so the signs and every other draw stay those of
        ``thrust_err`` alone) instead of being exactly ``thrust_err`` [fraction]; not
        part of ``truth=perturbed`` (``thrust_err_max=0.1``: thrust curves 5–10 % off).
    thrust_shape_err : each thruster's true curve is also off by an error that changes
        along it, which no gain describes: its thrust f × (1 + s·(1 − 2·|f|/f_max)), f_max
        the table's largest thrust that way, s = ±thrust_shape_err drawn per thruster and
        direction from a random stream of its own (+s near the band, −s at full thrust: a
        table off most near the band, a worn propeller losing most at full thrust)
        [fraction]; not part of ``truth=perturbed``.
    esc_band_us : each edge of each thruster's true dead band (its ESC's) lies up to this
        far from the profile's, uniform in ±esc_band_us per thruster and edge [µs], and
        the curve beyond it on that side moves with it (an ESC whose neutral and clock
        are off: :func:`~trimd.core.curve_error.offset_band`).
    esc_hunt : a thruster whose output falls inside its true dead band hunts at the band's
        edge, as an autopilot's integrator makes it do: it reports the first PWM out of
        the band on the output's side while the thrust it delivers (time-averaged over the
        hunting) rises linearly from 0 at neutral to the thrust of that first PWM, so the
        delivered thrust is whatever balances (:class:`~trimd.drivers.sim.thrusters.
        ThrusterBank`).

    What happens during the dive (:mod:`trimd.drivers.sim.scenario`):

    leak_N_min, leak_start_s, leak_at : water comes in at ``leak_N_min`` [N of weight per
        minute] from ``leak_start_s`` [s] on, at ``leak_at`` (a slot or ``x,y,z`` [m];
        "" the origin CG0), until ``leak_max_N`` [N] is in (0: no end).
    drop : ballast pieces lost, ``PIECE@SLOT@T_S`` joined by ``+`` (PIECE an inventory
        name or a mass in kg).
    pilot : a scripted pilot on the sticks (``dive``, ``transits``; "" none).
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
    ahrs_wander_deg: float = 0.0
    ahrs_wander_tau_s: float = 20.0
    attitude_wander_deg: float = 0.0
    attitude_wander_tau_s: float = 10.0
    depth_wander_m: float = 0.0
    depth_wander_tau_s: float = 20.0
    current_wander_m_s: float = 0.0
    current_wander_tau_s: float = 60.0
    gyro_wander_deg_s: float = 0.0
    gyro_wander_tau_s: float = 120.0
    torque_wander_deg: float = 0.0
    torque_wander_tau_s: float = 5.0
    thruster_dither_us: float = 0.0
    thruster_dither_tau_s: float = 0.3
    clock_jump_s: float = 0.0
    clock_jump_at_s: float = 60.0
    truth_seed: int = -1
    buoyancy_err: float = 0.0
    cob_err_mm: float = 0.0
    thrust_err: float = 0.0
    thrust_err_max: float = 0.0
    thrust_shape_err: float = 0.0
    esc_band_us: float = 0.0
    esc_hunt: bool = False
    leak_N_min: float = 0.0
    leak_start_s: float = 300.0
    leak_at: str = ""
    leak_max_N: float = 0.0
    drop: str = ""
    pilot: str = ""


#: ``disturb=real``: what a real vehicle at rest in a pool or calm sea shows (ArduSub's AHRS
#: wanders ≈ 0.1° over tens of seconds; MEMS gyro bias instability ≈ 0.01–0.05 °/s; a
#: pressure sensor and ripples ≈ 1 cm; thruster outputs reported at 0.4 of the attitude
#: rate, as a ground station's requested stream rates give). The PWM dither is small on
#: purpose: the controller already jitters the outputs with the sensor noise, and on the
#: BlueROV2 Heavy (vertical thrusters at the edge of the T200 deadband, small roll
#: stiffness) 3 µs of dither alone wanders roll by ≈ 1° (std); with this set its roll
#: shows ≈ 0.25° (std), ≈ 0.12° of it slow (5 s means); the Sabertooth ≈ 0.11° / 0.09°.
DISTURB_REAL: dict[str, Any] = {
    "ahrs_wander_deg": 0.1, "ahrs_wander_tau_s": 20.0,
    "attitude_wander_deg": 0.1, "attitude_wander_tau_s": 10.0,
    "depth_wander_m": 0.01, "depth_wander_tau_s": 20.0,
    "current_m_s": 0.03, "current_wander_m_s": 0.02, "current_wander_tau_s": 60.0,
    "gyro_wander_deg_s": 0.02, "gyro_wander_tau_s": 120.0,
    "thruster_dither_us": 0.5, "thruster_dither_tau_s": 0.3,
    "attitude_hz": 10.0, "thrusters_hz": 4.0,
}

#: ``truth=perturbed``: a vehicle that its profile does not describe exactly (buoyancy
#: 1 % off, centre of buoyancy 5 mm off, thrust 5 % off the table, each ESC's dead band up
#: to 4 µs off the profile's with its output hunting at the band edge).
TRUTH_PERTURBED: dict[str, Any] = {"buoyancy_err": 0.01, "cob_err_mm": 5.0, "thrust_err": 0.05,
                                   "esc_band_us": 4.0, "esc_hunt": True}

_FIELDS = {f.name: f for f in dataclasses.fields(SimConfig)}


def _defaults(fields: dict[str, Any]) -> dict[str, Any]:
    """The default value of each of ``fields``."""
    return {key: _FIELDS[key].default for key in fields}


#: Preset keys of a ``sim:`` URL: key → value → the fields it sets (``none`` and
#: ``profile`` set the fields of the other value back to their defaults).
PRESETS: dict[str, dict[str, dict[str, Any]]] = {
    "disturb": {"real": DISTURB_REAL, "none": _defaults(DISTURB_REAL)},
    "truth": {"perturbed": TRUTH_PERTURBED, "profile": _defaults(TRUTH_PERTURBED)},
}

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
    presets = {key: value.strip() for key, value in pairs if key in PRESETS}
    base = with_presets(base or SimConfig(), **presets)
    values: dict[str, Any] = {}
    for key, value in pairs:
        if key in PRESETS:
            continue
        if key not in _FIELDS:
            near = difflib.get_close_matches(key, [*_FIELDS, *PRESETS], n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ""
            raise LinkError(f"unknown sim option '{key}'{hint}")
        values[key] = _convert(key, value.strip())
    return dataclasses.replace(base, **values)


def with_presets(base: SimConfig | None = None, **presets: str) -> SimConfig:
    """``base`` with the fields of each preset (``disturb="real"``, ``truth="perturbed"``;
    :data:`PRESETS`) set, the rest of ``base`` kept.

    Raises
    ------
    LinkError
        For an unknown preset key or value.

    Examples
    --------
    >>> c = with_presets(SimConfig(seed=3), disturb="real", truth="perturbed")
    >>> c.seed, c.ahrs_wander_deg, c.cob_err_mm, c.thrusters_hz / c.attitude_hz
    (3, 0.1, 5.0, 0.4)
    """
    values: dict[str, Any] = {}
    for key, name in presets.items():
        if key not in PRESETS:
            raise LinkError(f"unknown sim preset '{key}' (known: {', '.join(PRESETS)})")
        if name not in PRESETS[key]:
            raise LinkError(f"sim option {key}={name}: expected one of "
                            f"{', '.join(PRESETS[key])}")
        values.update(PRESETS[key][name])
    return dataclasses.replace(base or SimConfig(), **values)


def _convert(key: str, value: str) -> bool | int | float | str:
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
