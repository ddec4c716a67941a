"""Excitation signals for open-loop identification experiments (method.md §5).

A :class:`Signal` is piecewise constant: six axis inputs in [−1, 1] (surge, sway, heave,
roll, pitch, yaw, as :class:`trimd.samples.OpenLoop`) that switch at given times. Only the
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
  (Ljungberg 2020); the several levels separate it from the linear term. Hold times are
  drawn uniformly in [max(0.5·T_i, 0.4 s), max(4·T_i, 2 s)]: the shortest holds put power
  near the corner frequency 1/T_i (transients: the mass), the longest reach the steady
  speed (the damping).
* Position-limited axes (heave: no restoring force at all; roll and pitch: only the
  metacentric one) always get **doublet** trains around their trim offset (the input that
  holds the vehicle still against W − B and the restoring moments of the profile):
  +A for T_d, −A for T_d, then a rest, so each pair returns the vehicle close to where it
  started. T_d is sized so that one half-doublet moves the vehicle at most a quarter of the
  depth envelope or half the tilt limit, and A is kept above the thrusters' deadband.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trimd.identify_model import STAGES, prior_values
from trimd.model import restoring_forces, thrust_configuration, thrust_from_pwm
from trimd.profile import Profile

__all__ = ["KINDS", "AxisDesign", "Signal", "axis_authority", "design_signal"]

FloatArray = NDArray[np.float64]

#: Signal kinds for the velocity axes.
KINDS = ("multistep", "prbs", "doublet")
_POSITION_AXES = (2, 3, 4)
_MEAN_FRACTION = 0.3
_LEVELS = (0.35, 0.7, 1.0)


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

    def at(self, t_s: float) -> tuple[float, float, float, float, float, float]:
        """The six axis inputs at ``t_s`` [s after the start]."""
        if t_s >= self.duration_s or t_s < 0:
            row = np.asarray(self.offsets)
        else:
            row = self.levels[max(0, int(np.searchsorted(self.t_s, t_s, side="right")) - 1)]
        a = [float(v) for v in row]
        return (a[0], a[1], a[2], a[3], a[4], a[5])


def axis_authority(profile: Profile) -> FloatArray:
    """Generalised force per unit axis input [N, N·m] (6,): Σ_j |T_ij|·f_j, f_j half the
    thrust range of thruster j at the nominal voltage."""
    T = thrust_configuration(profile.thrusters)
    half = []
    for t in profile.thrusters:
        lo = min(min(tb.pwm_us) for tb in t.curve.tables)
        hi = max(max(tb.pwm_us) for tb in t.curve.tables)
        f = thrust_from_pwm(t.curve, [lo, hi], profile.nominal_voltage_V)
        half.append(0.5 * float(f[1] - f[0]))
    out: FloatArray = np.abs(T) @ np.array(half)
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


def _design_axis(profile: Profile, i: int, kind: str, amplitude: float,
                 offset: float, depth_excursion_m: float, max_tilt_rad: float
                 ) -> AxisDesign:
    prior = prior_values(profile)
    names = list(prior)
    mass = prior[names[i]] + (profile.mass_kg if i < 3 else 0.0)
    lin, quad = prior[names[6 + i]], prior[names[12 + i]]
    auth = float(axis_authority(profile)[i])
    A = amplitude
    if i in _POSITION_AXES:
        A = max(A, min(1.0, 1.5 * _deadband_fraction(profile)))
    speed = _steady_speed(A * auth, lin, quad)
    T = mass / max(abs(lin) + 2 * abs(quad) * speed, 1e-12)
    lo, hi = max(0.5 * T, 0.4), max(4 * T, 2.0)
    if i in _POSITION_AXES:
        limit = 0.25 * depth_excursion_m if i == 2 else 0.5 * max_tilt_rad
        longest = limit / max(speed, 1e-9)
        hi = max(min(hi, longest), 0.1)
        lo = min(lo, hi)
        kind = "doublet"
    return AxisDesign(i, kind, A, offset, T, (lo, hi))


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
                  depth_excursion_m: float = 5.0) -> Signal:
    """The excitation of ``stage`` (module docstring).

    Parameters
    ----------
    profile : priors for sizing, tilt limit (``procedure.max_tilt_deg``).
    stage : uvr, uwq or uvwpqr.
    kind : signal of the velocity axes, one of :data:`KINDS`.
    amplitude : A in (0, 1], the largest input of each velocity axis (position-limited
        axes use it too unless the deadband needs more).
    duration_s : length [s]; afterwards the inputs are the trim offsets.
    seed : random seed of hold times, signs and levels.
    depth_excursion_m : the depth envelope the heave doublets are sized to [m].

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
    rng = np.random.default_rng(seed)
    designs = tuple(_design_axis(profile, i, kind, amplitude, offsets[i], depth_excursion_m,
                                 math.radians(profile.procedure.max_tilt_deg))
                    for i in STAGES[stage].axes)
    series = {d.axis: _axis_series(d, duration_s, rng) for d in designs}
    times = np.unique(np.concatenate([[0.0]] + [[t for t, _ in s] for s in series.values()]))
    times = times[times < duration_s]
    levels = np.tile(np.asarray(offsets), (len(times), 1))
    for axis, s in series.items():
        t_ax = np.array([t for t, _ in s])
        v_ax = np.array([v for _, v in s])
        idx = np.searchsorted(t_ax, times, side="right") - 1
        levels[:, axis] = np.clip(v_ax[np.maximum(idx, 0)], -1.0, 1.0)
    return Signal(times, levels, duration_s, offsets, designs)
