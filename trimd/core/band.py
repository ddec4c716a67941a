"""The band loads: what to hang on a vehicle so that, held level, its vertical thrusters
move it with the first µs of their thrust and hunt at the edges of their ESCs' dead
bands, which the hold then shows (docs/method.md §7, "The band calibration").

A calibration experiment compares two holds, so an offset of a band edge cancels in it;
the holds' hunting spikes show the edges themselves (:mod:`trimd.core.hunting`). A
trimmed vehicle is buoyant by whatever its ballast left: held level its vertical
thrusters push down, beyond their lower edges or at them. A trim of the untrimmed
vehicle, heavy with its new payload, has them push up, beyond the upper edges, which
nothing showed. The upper band load makes the vehicle heavy by :func:`band_margin_N`,
half what the lifting thrusters' first µs beyond their upward edges would lift, so that
each of them lifts its share from within that µs: it hunts at its upper edge. The lower
band load makes it buoyant by the margin of the downward edges, so that they hunt at
their lower edges. Each load hangs at weight slots (floats at float slots, whichever
the vehicle needs) whose x and y moments cancel, so that the hold's roll and pitch
demands stay as they were.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from trimd.core.errors import UsageError
from trimd.core.hunting import LIFTING
from trimd.core.model import band_at, thrust_configuration, thrust_from_pwm
from trimd.core.profile import BallastSlot, Profile

__all__ = ["BAND_SHARE", "BandLoad", "band_load", "band_margin_N"]

#: The share of the lifting thrusters' first-µs thrust the band load aims the vehicle's
#: W − B at: the middle of the window in which each lifts from within that µs.
BAND_SHARE = 0.5
#: The cost of 1 N·m of net moment the slots cannot cancel, against 1 N·m of load lever.
_MOMENT_COST = 1e3


@dataclass(frozen=True)
class BandLoad:
    """What to hang for the band hold.

    Attributes
    ----------
    pieces : (slot name, net downward force in water [N]; negative: a float's lift), the
        slots' order, none of zero.
    margin_N : the W − B [N] the loaded vehicle aims at (:func:`band_margin_N`; negative
        for the lower edges: buoyant).
    moment_Nm : the x and y net moments [N·m] the load adds (zero when the slots can
        cancel them).
    """

    pieces: tuple[tuple[str, float], ...]
    margin_N: float
    moment_Nm: tuple[float, float]


def band_margin_N(profile: Profile, upward: bool = True) -> float:
    """:data:`BAND_SHARE` of what the lifting thrusters (their thrust at least
    :data:`~trimd.core.hunting.LIFTING` vertical) lift (``upward``; else push down) with
    the first µs beyond their dead bands' edges on that side, at the profile's nominal
    voltage [N]: the |W − B| at which each moves the vehicle from within that µs.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> heavy = load_profile("bluerov2-heavy")
    >>> round(band_margin_N(heavy), 2), round(band_margin_N(heavy, upward=False), 2)
    (0.13, 0.16)
    """
    T = thrust_configuration(profile.thrusters)
    v = profile.nominal_voltage_V
    push = 0.0
    for i, t in enumerate(profile.thrusters):
        if abs(T[2, i]) < LIFTING:
            continue
        low, high = band_at(t.curve, v)
        lifts_forward = T[2, i] < 0            # FRD: lifting is −z
        pwm = high + 1 if lifts_forward == upward else low - 1
        push += abs(float(thrust_from_pwm(t.curve, pwm, v)) * T[2, i])
    return float(BAND_SHARE * push)


def band_load(profile: Profile, w_minus_b_N: float, upward: bool = True) -> BandLoad:
    """The load that makes a vehicle of ``w_minus_b_N`` [N] (a level hold's estimate, with
    the vehicle's calibration) heavy by :func:`band_margin_N` (``upward``; else buoyant
    by the downward margin): net down force at weight slots (floats' lift at float slots
    when the vehicle needs lift) whose x and y moments cancel where they can, else least,
    the slots nearest the vehicle's centre first (scipy's ``linprog``). UsageError when
    the slots cannot take it."""
    margin = band_margin_N(profile, upward) * (1.0 if upward else -1.0)
    need = margin - w_minus_b_N
    sign = 1.0 if need > 0 else -1.0
    g = profile.gravity_m_s2

    def cap(slot: BallastSlot) -> float:
        """What ``slot`` takes of the load's kind [N]."""
        return (slot.max_weight_kg if sign > 0 else slot.max_float_kg) * g

    slots = [s for s in profile.slots if cap(s) > 0]
    capacity = sum(cap(s) for s in slots)
    if not slots or capacity < abs(need):
        kind = "weight" if sign > 0 else "float"
        raise UsageError(f"the band hold needs {abs(need):.2f} N of {kind} (the vehicle "
                         f"at {w_minus_b_N:+.2f} N, the band at {margin:+.2f} N): its "
                         f"{kind} slots take {capacity:.2f} N", "trimd calibrate --band")
    P = np.array([s.position_m for s in slots])
    n = len(slots)
    # w ≥ 0 per slot [N] and the moments' parts the slots leave, m⁺ − m⁻ (x, y)
    cost = np.r_[np.abs(P[:, 0]) + np.abs(P[:, 1]), np.full(4, _MOMENT_COST)]
    A_eq = np.zeros((3, n + 4))
    A_eq[0, :n] = 1.0
    A_eq[1, :n], A_eq[1, n:n + 2] = P[:, 0], (1.0, -1.0)
    A_eq[2, :n], A_eq[2, n + 2:] = P[:, 1], (1.0, -1.0)
    bounds = [(0.0, cap(s)) for s in slots]
    found = linprog(cost, A_eq=A_eq, b_eq=[abs(need), 0.0, 0.0],
                    bounds=bounds + [(0.0, None)] * 4, method="highs")
    w = np.asarray(found.x[:n]) * sign
    pieces = tuple((s.name, float(f)) for s, f in zip(slots, w, strict=True)
                   if abs(f) > 1e-9 * max(1.0, abs(need)))
    moment = (float(P[:, 0] @ w), float(P[:, 1] @ w))
    return BandLoad(pieces, margin, moment)
