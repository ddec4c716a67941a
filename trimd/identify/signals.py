"""Excitation signals for open-loop identification experiments (docs/method.md §5).

A :class:`Signal` is piecewise constant: six axis inputs in [−1, 1] (surge, sway, heave,
roll, pitch, yaw, as :class:`trimd.core.samples.OpenLoop`) that switch at given times. Only the
axes of the stage move; the others stay at their trim offset.

Design, per axis, from the profile's priors (mass, added mass, damping, restoring terms,
thruster authority): they only size the experiment, the fit never starts from them.

* Authority a_i [N or N·m per unit input]: Σ_j |T_ij|·f_j, f_j half the thrust range of
  thruster j (the thrust configuration T, Fossen eq. 11.3).
* Time constant of DOF i at the input amplitude A: T_i = M_i / (|D_i| + 2·|D_i|i||·ν_ss),
  ν_ss the steady speed where the damping balances A·a_i.
* Velocity axes (surge, sway, yaw: nothing limits how far the vehicle goes) get a
  **multistep** (default: levels A·(μ + (1 − μ)·s·U) with a random sign s = ±1, a random
  level U ∈ {0.35, 0.7, 1}, and the mean fraction μ = 0.3), a **prbs** (U = 1) or a
  **doublet** train. The non-zero mean is what makes the quadratic damping identifiable
  (Ljungberg 2020); the several levels separate it from the linear term. Where the
  prior's steady speed at the amplitude A stays below :data:`TARGET_SPEED` (0.4 m/s or
  rad/s, the fastest speed trimd judges a damping force at), A is raised until it reaches
  it, at most to full authority (the Sabertooth yawed at 0.05–0.08 rad/s at A = 0.6,
  close to its gyro's noise). Hold times are
  drawn uniformly in [max(0.5·T_i, 0.4 s), max(4·T_i, 2 s)]: the shortest holds put power
  near the corner frequency 1/T_i (transients: the mass), the longest reach the steady
  speed (the damping).
* Position-limited axes (heave: no restoring force at all; roll and pitch: only the
  metacentric one) always get **doublet** trains around their trim offset (the input that
  holds the vehicle still against W − B and the restoring moments of the profile):
  +A for T_d, −A for T_d, then a rest, so each pair returns the vehicle close to where it
  started. T_d is sized so that one half-doublet moves the vehicle at most a quarter of the
  depth envelope or half the tilt limit (from rest under the force A·a_i, the
  excursion after T is at most min(ν_ss·T, A·a_i·T²/(2·M_i))), and A is kept above the
  thrusters' deadband.
* **Attitude hold** (:class:`HoldAxis`). Thrusters away from the centre of gravity turn
  a force into a moment: on the BlueROV2 Heavy, 8.5 cm below it, full surge makes ≈ 11 N·m
  of pitch against a metacentric stiffness of 1.3 N·m/rad, so no open-loop amplitude above
  the deadband keeps the attitude in the envelope. The moment c_ki that a unit input on
  axis i makes about roll or pitch (k) is bounded from the geometry
  (:func:`axis_forces`: every thruster pushing the way that helps axis i). When the
  excited axes can make a moment d_k = Σ_i |c_ki|·A_i about k, trimd closes a PID loop on
  that angle (target level) during the experiment, with a triple closed-loop pole at −ω_k
  on the prior inertia sum J_k: Kp = 3·J·ω², Ki = J·ω³, Kd = 3·J·ω. The peak tilt of that
  loop after a step moment d is 2e⁻²·d/(J·ω²) ≈ 0.27·d/(J·ω²); ω_k is the smallest that
  keeps it below a quarter of the tilt limit, at most ``hold_bandwidth_rad_s`` (the loop
  runs over the link at the telemetry rate and through the thrusters' spin-up lag); when
  that is not enough, the coupling axes' amplitudes are scaled down until it is. On a
  roll or pitch axis the stage excites, the doublets add to the loop's output and their
  amplitude is limited the same way to half the tilt limit (unless even their shortest
  half, ``_MIN_HOLD_S``, is safe open loop). The thruster outputs
  are recorded whatever computed them, so the fit sees the total τ, feedback included
  (no process noise enters the loop other than through measured τ).
* **Depth hold** (``Signal.depth_hold``) in every stage: the heave trim offset alone
  cannot keep the depth, since a small one falls inside the thrusters' deadband (the
  Sabertooth's 58 N of buoyancy is input 0.035), a vehicle whose buoyancy differs from
  the prior's by 1 % (117 N on the Sabertooth) has another trim, and surge at a pitch
  moves it up or down; it drifts out of the depth envelope (an unseen Sabertooth's uwq
  stage left a 5 m envelope at 80–280 s). A PI loop on the depth error, added to the
  offset, does: with the prior heave mass M and linear damping D as the loop's
  derivative term, M·s³ + D·s² + kp·s + ki has a triple pole at −ω for kp = 3·M·ω²,
  ki = M·ω³ and ω = D/(3·M) (at most 0.5 rad/s); its integral winds through the deadband
  and takes the buoyancy error. Where the stage excites heave, ω is also at most a fifth
  of the heave doublets' slowest frequency π/T_d (:data:`_DEPTH_HOLD_BELOW`), so the hold
  takes the drift and leaves the doublets. Its output is in the recorded τ like any
  other: the fit sees the total thrust, the hold's share included.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from trimd.core.model import restoring_forces, thrust_configuration, thrust_from_pwm
from trimd.core.profile import Profile
from trimd.core.types import FloatArray
from trimd.identify.model import HYDRO_NAMES, STAGES, prior_values, restoring_vector

__all__ = ["KINDS", "TARGET_SPEED", "AxisDesign", "HoldAxis", "Signal", "axis_authority",
           "axis_forces", "design_signal"]

_HEAVE = 2
#: Largest depth-hold integral output [input]: the trim of W − B, with room to spare.
_MAX_TRIM_INPUT = 0.5
#: Largest bandwidth of the depth hold [rad/s].
_MAX_DEPTH_BANDWIDTH_RAD_S = 0.5
#: Under heave doublets, the depth hold's bandwidth is at most this share of their
#: slowest angular frequency, π over the longest half-doublet.
_DEPTH_HOLD_BELOW = 0.2

#: Signal kinds for the velocity axes.
KINDS = ("multistep", "prbs", "doublet")
_POSITION_AXES = (2, 3, 4)
_MEAN_FRACTION = 0.3
_LEVELS = (0.35, 0.7, 1.0)
_TILT_AXES = (3, 4)
#: The speed [m/s or rad/s] a velocity axis's largest level should reach by the prior
#: (the faster of the two speeds the identification's damping forces are judged at).
TARGET_SPEED = 0.4
#: Shortest hold (or half-doublet) [s]: several samples and thruster spin-up times.
_MIN_HOLD_S = 0.4
#: Peak of t²/2·e^(−ωt)·ω² (at t = 2/ω): the largest error of a triple-pole PID loop after
#: a step disturbance d is this times d/(J·ω²).
_PEAK = 2.0 * math.exp(-2.0)


@dataclass(frozen=True, slots=True)
class HoldAxis:
    """PID attitude hold of one tilt axis (3 roll, 4 pitch) towards level, in axis-input
    units: ``kp`` per rad, ``ki`` per rad·s, ``kd`` per rad/s; ``bandwidth_rad_s`` is ω of
    the triple closed-loop pole; the integral term is limited to ±``i_limit`` (input)."""

    axis: int
    kp: float
    ki: float
    kd: float
    bandwidth_rad_s: float
    i_limit: float


@dataclass(frozen=True, slots=True)
class AxisDesign:
    """How one axis is excited: signal kind, amplitude A and trim offset (inputs), the
    prior time constant [s], and the range of hold (or half-doublet) times [s]."""

    axis: int
    kind: str
    amplitude: float
    offset: float
    time_constant_s: float
    hold_s: tuple[float, float]


@dataclass(frozen=True, eq=False)
class Signal:
    """Piecewise-constant open-loop inputs: ``levels[k]`` from ``t_s[k]`` [s after the
    start] until ``t_s[k + 1]``; the trim offsets after ``duration_s``."""

    t_s: FloatArray
    levels: FloatArray
    duration_s: float
    offsets: tuple[float, ...]
    axes: tuple[AxisDesign, ...]
    hold: tuple[HoldAxis, ...] = ()
    depth_hold: HoldAxis | None = None

    def at(self, t_s: float) -> tuple[float, float, float, float, float, float]:
        """The six axis inputs at ``t_s`` [s after the start]."""
        if t_s >= self.duration_s or t_s < 0:
            row = np.asarray(self.offsets)
        else:
            row = self.levels[max(0, int(np.searchsorted(self.t_s, t_s, side="right")) - 1)]
        a = [float(v) for v in row]
        return (a[0], a[1], a[2], a[3], a[4], a[5])


def axis_forces(profile: Profile) -> FloatArray:
    """Generalised force [N, N·m] per unit input of each axis when every thruster that acts
    on that axis pushes the way that helps it, (6, 6), column i for axis i:
    T·(sign(T_i·)·f), f_j half the thrust range of thruster j at the nominal voltage. The
    diagonal is the axis authority; the off-diagonal entries bound the forces and moments
    an axis makes on the others (a mixer that balances them makes less)."""
    T = thrust_configuration(profile.thrusters)
    half = []
    for t in profile.thrusters:
        lo = min(min(tb.pwm_us) for tb in t.curve.tables)
        hi = max(max(tb.pwm_us) for tb in t.curve.tables)
        f = thrust_from_pwm(t.curve, [lo, hi], profile.nominal_voltage_V)
        half.append(0.5 * float(f[1] - f[0]))
    out: FloatArray = T @ (np.sign(T) * np.array(half)).T
    return out


def axis_authority(profile: Profile) -> FloatArray:
    """Generalised force per unit axis input [N, N·m] (6,): Σ_j |T_ij|·f_j, f_j half the
    thrust range of thruster j at the nominal voltage (the diagonal of
    :func:`axis_forces`)."""
    out: FloatArray = np.diag(axis_forces(profile)).copy()
    return out


def _deadband_fraction(profile: Profile) -> float:
    """Largest deadband of the thrusters as a fraction of their PWM half-range."""
    fractions = []
    for t in profile.thrusters:
        for tb in t.curve.tables:
            half = 0.5 * (max(tb.pwm_us) - min(tb.pwm_us))
            fractions.append(0.5 * (tb.deadband_us[1] - tb.deadband_us[0]) / half)
    return max(fractions, default=0.0)


def _steady_speed(force: float, lin: float, quad: float) -> float:
    """ν ≥ 0 with |quad|·ν² + |lin|·ν = force (damping balances a constant force)."""
    a, b = abs(quad), abs(lin)
    if a < 1e-12:
        return force / max(b, 1e-12)
    return (-b + math.sqrt(b * b + 4 * a * force)) / (2 * a)


def _velocity_amplitude(profile: Profile, i: int, amplitude: float) -> float:
    """The amplitude of velocity axis ``i``: ``amplitude``, raised where the prior's
    steady speed under it stays below :data:`TARGET_SPEED` until it reaches it, at most
    1 (full authority)."""
    prior = prior_values(profile)
    lin, quad = abs(prior[HYDRO_NAMES[6 + i]]), abs(prior[HYDRO_NAMES[12 + i]])
    needed = (lin * TARGET_SPEED + quad * TARGET_SPEED ** 2) / float(axis_authority(profile)[i])
    return min(max(amplitude, needed), 1.0)


def _design_axis(profile: Profile, i: int, kind: str, amplitude: float,
                 offset: float, depth_excursion_m: float, max_tilt_rad: float
                 ) -> AxisDesign:
    """Time constant and hold times of axis ``i`` at ``amplitude`` (module docstring)."""
    prior = prior_values(profile)
    names = list(prior)
    mass = prior[names[i]] + (profile.mass_kg if i < 3 else 0.0)
    lin, quad = prior[names[6 + i]], prior[names[12 + i]]
    force = amplitude * float(axis_authority(profile)[i])
    speed = _steady_speed(force, lin, quad)
    T = mass / max(abs(lin) + 2 * abs(quad) * speed, 1e-12)
    lo, hi = max(0.5 * T, _MIN_HOLD_S), max(4 * T, 2.0)
    if i in _POSITION_AXES:
        limit = 0.25 * depth_excursion_m if i == 2 else 0.5 * max_tilt_rad
        # from rest, the excursion after T is at most min(speed·T, force·T²/(2·mass))
        longest = max(limit / max(speed, 1e-9),
                      math.sqrt(2 * limit * mass / max(force, 1e-12)))
        hi = max(min(hi, longest), 0.1)
        lo = min(lo, hi)
        kind = "doublet"
    return AxisDesign(i, kind, amplitude, offset, T, (lo, hi))


def _design_hold(profile: Profile, axes: tuple[int, ...], amplitudes: dict[int, float],
                 max_tilt_rad: float, max_bandwidth_rad_s: float) -> tuple[HoldAxis, ...]:
    """The attitude hold of roll and pitch (module docstring); lowers ``amplitudes`` in
    place where the largest bandwidth cannot hold the moments of the excited axes."""
    forces = axis_forces(profile)
    prior = prior_values(profile)
    allowance_rad, doublet_rad = 0.25 * max_tilt_rad, 0.5 * max_tilt_rad
    # metacentric stiffness [N·m/rad] of roll and pitch: −∂g/∂φ, −∂g/∂θ at level
    q = restoring_vector(profile)
    stiffness = (float(q[3]), float(q[3]))
    out = []
    for k in _TILT_AXES:
        J = prior[HYDRO_NAMES[k]]
        others = [i for i in axes if i != k]
        moment = sum(abs(forces[k, i]) * amplitudes[i] for i in others)
        if moment <= 1e-9 * forces[k, k]:
            continue   # nothing the stage does turns the vehicle about this axis
        needed = math.sqrt(_PEAK * moment / (J * allowance_rad))
        w = min(needed, max_bandwidth_rad_s)
        for i in others:
            amplitudes[i] *= (w / needed) ** 2
        if k in amplitudes:
            # a doublet is safe when the hold keeps its step response within the tilt
            # allowance, or when, open loop, even its shortest half (_MIN_HOLD_S) turns
            # the vehicle by less (from rest: ½·(F/J)·T²)
            closed = doublet_rad * J * w * w / _PEAK
            open_ = 2 * doublet_rad * J / _MIN_HOLD_S ** 2
            amplitudes[k] = min(amplitudes[k], max(closed, open_) / forces[k, k])
        a = forces[k, k]
        kp = max(3 * J * w * w - stiffness[k - 3], 0.0)   # the restoring moment helps
        out.append(HoldAxis(k, kp / a, J * w ** 3 / a, 3 * J * w / a, w, 1.0))
    return tuple(out)


def _design_depth_hold(profile: Profile, heave: AxisDesign | None) -> HoldAxis | None:
    """The depth hold (module docstring): PID on the depth error with a triple pole at
    −ω, ω = D/(3·M) from the prior heave mass M and linear damping D (the damping is the
    loop's derivative term), at most :data:`_MAX_DEPTH_BANDWIDTH_RAD_S` and, under heave
    doublets, at most :data:`_DEPTH_HOLD_BELOW` of their slowest angular frequency
    π/T_d; None without linear heave damping."""
    prior = prior_values(profile)
    M = profile.mass_kg + prior["Z_wdot"]
    D = abs(prior["Z_w"])
    if D <= 0:
        return None  # without damping a PI loop on a mass is not stable
    w = min(D / (3 * M), _MAX_DEPTH_BANDWIDTH_RAD_S)
    if heave is not None:
        w = min(w, _DEPTH_HOLD_BELOW * math.pi / heave.hold_s[1])
    a = float(axis_authority(profile)[_HEAVE])
    return HoldAxis(_HEAVE, 3 * M * w * w / a, M * w ** 3 / a, 0.0, w, _MAX_TRIM_INPUT)


def _axis_series(d: AxisDesign, duration_s: float, rng: np.random.Generator
                 ) -> list[tuple[float, float]]:
    """(start time, level) pairs of one axis."""
    out: list[tuple[float, float]] = []
    t = 0.0
    lo, hi = d.hold_s
    while t < duration_s:
        hold = float(rng.uniform(lo, hi))
        if d.kind == "doublet":
            s = 1.0 if rng.random() < 0.5 else -1.0
            level = d.amplitude * _LEVELS[int(rng.integers(len(_LEVELS)))]
            hold = min(hold, hi)
            out += [(t, d.offset + s * level), (t + hold, d.offset - s * level),
                    (t + 2 * hold, d.offset)]
            t += 2 * hold + float(rng.uniform(lo, hi))
            continue
        s = 1.0 if rng.random() < 0.5 else -1.0
        u = 1.0 if d.kind == "prbs" else _LEVELS[int(rng.integers(len(_LEVELS)))]
        level = d.amplitude * (_MEAN_FRACTION + (1 - _MEAN_FRACTION) * s * u)
        out.append((t, d.offset + level))
        t += hold
    return out


def design_signal(profile: Profile, stage: str, *, kind: str = "multistep",
                  amplitude: float = 0.6, duration_s: float = 120.0, seed: int = 0,
                  depth_excursion_m: float = 5.0, hold_bandwidth_rad_s: float = 4.0
                  ) -> Signal:
    """The excitation of ``stage`` (module docstring).

    Parameters
    ----------
    profile : priors for sizing, tilt limit (``procedure.max_tilt_deg``).
    stage : uvr, uwq or uvwpqr.
    kind : signal of the velocity axes, one of :data:`KINDS`.
    amplitude : A in (0, 1], the largest input of each velocity axis unless it needs more
        to reach :data:`TARGET_SPEED` (position-limited axes use it too unless the
        deadband needs more); the attitude hold may lower both.
    duration_s : length [s]; afterwards the inputs are the trim offsets.
    seed : random seed of hold times, signs and levels.
    depth_excursion_m : the depth envelope the heave doublets are sized to [m].
    hold_bandwidth_rad_s : the largest bandwidth ω of the attitude hold [rad/s].

    Raises
    ------
    ValueError
        For an unknown stage or kind, or an amplitude outside (0, 1].
    """
    if stage not in STAGES:
        raise ValueError(f"unknown stage '{stage}' (stages: {', '.join(STAGES)})")
    if kind not in KINDS:
        raise ValueError(f"unknown signal '{kind}' (signals: {', '.join(KINDS)})")
    if not 0 < amplitude <= 1:
        raise ValueError(f"amplitude must be in (0, 1], got {amplitude}")
    auth = axis_authority(profile)
    g0 = restoring_forces(0.0, 0.0, profile.weight_N, profile.buoyancy_N, (0.0, 0.0, 0.0),
                          profile.r_b_m)
    offsets = tuple(float(np.clip(g0[i] / auth[i], -0.5, 0.5)) for i in range(6))
    max_tilt = math.radians(profile.procedure.max_tilt_deg)
    floor = min(1.0, 1.5 * _deadband_fraction(profile))
    axes = STAGES[stage].axes
    # roll and pitch ask for full authority: the attitude hold's limit and the length of
    # a half-doublet keep them within half the tilt limit (a metacentrically stiff
    # vehicle such as the Sabertooth otherwise pitched 4–7° of 12.5° at 0.04–0.08 rad/s,
    # where the gyro's noise held the NRMSE of q below 90 % even for the true model)
    amplitudes = {i: 1.0 if i in _TILT_AXES else max(amplitude, floor)
                  if i in _POSITION_AXES else _velocity_amplitude(profile, i, amplitude)
                  for i in axes}
    hold = _design_hold(profile, axes, amplitudes, max_tilt, hold_bandwidth_rad_s)
    rng = np.random.default_rng(seed)
    designs = tuple(_design_axis(profile, i, kind, amplitudes[i], offsets[i],
                                 depth_excursion_m, max_tilt) for i in axes)
    depth_hold = _design_depth_hold(profile, next((d for d in designs if d.axis == _HEAVE),
                                                  None))
    series = {d.axis: _axis_series(d, duration_s, rng) for d in designs}
    times = np.unique(np.concatenate([[0.0]] + [[t for t, _ in s] for s in series.values()]))
    times = times[times < duration_s]
    levels = np.tile(np.asarray(offsets), (len(times), 1))
    for axis, s in series.items():
        t_ax = np.array([t for t, _ in s])
        v_ax = np.array([v for _, v in s])
        idx = np.searchsorted(t_ax, times, side="right") - 1
        levels[:, axis] = np.clip(v_ax[np.maximum(idx, 0)], -1.0, 1.0)
    return Signal(times, levels, duration_s, offsets, designs, hold, depth_hold)
