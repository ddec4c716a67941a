"""The band loads: what to hang on a vehicle so that, held level, its vertical thrusters
move it with the first µs of their thrust and hunt at the edges of their ESCs' dead
bands, which the hold then shows (docs/method.md §7, "The band calibration").

A calibration experiment compares two holds, so an offset of a band edge cancels in it;
the holds' hunting spikes show the edges themselves (:mod:`trimd.core.hunting`). A
trimmed vehicle is buoyant by whatever its ballast left: held level its vertical
thrusters push down, beyond their lower edges or at them. A trim of the untrimmed
vehicle, heavy with its new payload, has them push up, beyond the upper edges, which
nothing showed. The upper band load makes the vehicle what :func:`band_target` aims at:
heavy by :func:`band_margin_N`, half what the lifting thrusters' first µs beyond their
upward edges would lift, with the net moments that have each of them lift half its own
first µs, so that each, not only their sum, works from within that µs: it hunts at its
upper edge. The lower band load makes it buoyant by the margin of the downward edges,
likewise. Each load is weights at weight slots and floats at float slots, from what the
first hold read of the vehicle's W − B and x, y net moments: a trimmed vehicle's moments
are what its ballast left, and on the Sabertooth (three vertical thrusters, 0.9 m from
its centre) they are several times what one thruster's first µs turns it by
(docs/method.md §7).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from trimd.ballast.highs import solve
from trimd.core.errors import UsageError
from trimd.core.hunting import LIFTING, EdgeObservation
from trimd.core.model import band_at, thrust_configuration, thrust_from_pwm
from trimd.core.profile import Profile
from trimd.core.types import FloatArray

__all__ = ["BAND_SHARE", "BandLoad", "band_load", "band_margin_N", "band_target", "unhunted"]

#: The share of the lifting thrusters' first-µs thrust the band load aims each of them at:
#: the middle of the window in which each moves the vehicle from within that µs.
BAND_SHARE = 0.5
#: The band load's costs (:func:`band_load`), against 1 N of load at the vehicle's centre
#: (whose 1 % is 0.01 N of the experiment's error): a piece (≈ 50 g of load); 1 N·m of
#: net moment missed within a third of its 1σ (a miss the hold's ± allows, which a piece
#: is worth only where that σ is ≳ 0.15 N·m: on the Sabertooth, not on a Heavy); and
#: beyond that (a bound).
_PIECE_COST = 0.5
_MOMENT_COST = 10.0
_BEYOND_COST = 1e6
#: The branch-and-bound nodes a band load's search may take (a few slots: tens).
_NODES = 10_000


@dataclass(frozen=True)
class BandLoad:
    """What to hang for the band hold.

    Attributes
    ----------
    pieces : (slot name, net downward force in water [N]; negative: a float's lift), the
        slots' order, none of zero.
    aim : the q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b] [N, N·m] the loaded vehicle aims
        at (:func:`band_target`).
    miss_Nm : the x and y net moments [N·m] by which the loaded vehicle, as the hold read
        it, misses that aim (within their 1σ, or what the slots cannot make).
    """

    pieces: tuple[tuple[str, float], ...]
    aim: tuple[float, float, float]
    miss_Nm: tuple[float, float]

    @property
    def margin_N(self) -> float:
        """The W − B [N] the loaded vehicle aims at (negative for the lower edges:
        buoyant)."""
        return self.aim[0]


def _band_sides(profile: Profile, upward: bool) -> dict[int, bool]:
    """Lifting thruster (index: its thrust at least :data:`~trimd.core.hunting.LIFTING`
    vertical) → whether the edge at which it lifts (``upward``; else pushes down) lies above
    neutral (FRD: a thruster lifts with its thrust along −z)."""
    T = thrust_configuration(profile.thrusters)
    return {i: bool(T[2, i] < 0) == upward for i in range(len(profile.thrusters))
            if abs(T[2, i]) >= LIFTING}


def unhunted(profile: Profile, spikes: Sequence[EdgeObservation], upward: bool = True
             ) -> tuple[int, ...]:
    """The lifting thrusters (indices, the profile's order) that a band hold's hunting
    ``spikes`` (:func:`~trimd.core.hunting.hunting_spikes`) do not show at the edge at
    which they lift (``upward``; else push down): those whose edge that hold did not
    read."""
    shown = {(o.thruster, o.positive) for o in spikes}
    return tuple(i for i, above in _band_sides(profile, upward).items()
                 if (i, above) not in shown)


def band_target(profile: Profile, upward: bool = True) -> FloatArray:
    """q = [W − B, W·x_g − B·x_b, W·y_g − B·y_b] [N, N·m], body FRD, of the vehicle that,
    held level, each lifting thruster (its thrust at least
    :data:`~trimd.core.hunting.LIFTING` vertical) holds with :data:`BAND_SHARE` of what it
    lifts (``upward``; else pushes down) with the first µs beyond its dead band's edge on
    that side, at the profile's nominal voltage: the thrusters' shares of the net moments
    as well as of W − B, so that each of them, not only their sum, works from within that
    µs.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> [round(float(x), 2) for x in band_target(load_profile("sabertooth-dh2"))]
    [1.74, -0.52, 0.0]
    """
    T = thrust_configuration(profile.thrusters)
    v = profile.nominal_voltage_V
    f = np.zeros(len(profile.thrusters))
    for i, above in _band_sides(profile, upward).items():
        curve = profile.thrusters[i].curve
        low, high = band_at(curve, v)
        f[i] = BAND_SHARE * float(thrust_from_pwm(curve, high + 1 if above else low - 1, v))
    tau = T @ f
    q = np.array([-tau[2], tau[4], -tau[3]])      # level: Z = −q₀, K = −q₂, M = q₁
    return np.where(np.abs(q) > 1e-12 * np.abs(q).max(), q, 0.0)   # no −0.00 for people


def band_margin_N(profile: Profile, upward: bool = True) -> float:
    """|W − B| [N] of :func:`band_target`: :data:`BAND_SHARE` of what the lifting
    thrusters lift (``upward``; else push down) with the first µs beyond their dead bands'
    edges on that side.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> heavy = load_profile("bluerov2-heavy")
    >>> round(band_margin_N(heavy), 2), round(band_margin_N(heavy, upward=False), 2)
    (0.13, 0.16)
    """
    return abs(float(band_target(profile, upward)[0]))


def band_load(profile: Profile, q: ArrayLike, upward: bool = True,
              q_sd: ArrayLike = (0.0, 0.0, 0.0)) -> BandLoad:
    """The load that makes a vehicle of ``q`` = [W − B, W·x_g − B·x_b, W·y_g − B·y_b] [N, N·m]
    (a level hold's estimate, with the vehicle's calibration; ``q_sd`` its 1σ) into
    :func:`band_target` (``upward``; else the downward one): net down force at weight
    slots and lift at float slots, chosen by scipy's ``milp``
    (:func:`~trimd.ballast.highs.solve`). W − B exactly; the moments moved toward the
    aim by their distance d from it shrunk by (1 − σ²/d²)⁺ (the positive part of James
    and Stein's estimator: nearly all of a distance many σ long, none of one within 1σ,
    as a trimmed vehicle's small moments read with the profile alone may be: the load
    then leaves them), to within a third of that 1σ (which adds a twentieth to their
    error; where the slots cannot, the least miss); at the least cost of load (its
    pieces' uncertainty is a share of their weight: no big weight against a big float),
    pieces (no gram of foam for a moment the hold knows to a few hundredths of a N·m)
    and miss (:data:`_PIECE_COST`), the slots nearest the vehicle's centre first.
    UsageError when the slots cannot take the load's W − B."""
    aim = band_target(profile, upward)
    now = np.asarray(q, dtype=float)[:3]
    known = np.abs(np.asarray(q_sd, dtype=float)[:3])
    need = aim - now            # the moments' part shrunk by (1 − σ²/d²)⁺
    d = need[1:]
    need[1:] = d * np.maximum(1.0 - known[1:]**2 / np.maximum(d**2, 1e-300), 0.0)
    g = profile.gravity_m_s2
    slots = profile.slots
    caps = np.array([[s.max_weight_kg * g for s in slots], [s.max_float_kg * g for s in slots]])
    capacity = float(caps[0 if need[0] > 0 else 1].sum())
    if capacity < abs(need[0]):
        kind = "weight" if need[0] > 0 else "float"
        raise UsageError(f"the band hold needs {abs(need[0]):.2f} N of {kind} (the vehicle "
                         f"at {now[0]:+.2f} N, the band at {aim[0]:+.2f} N): its "
                         f"{kind} slots take {capacity:.2f} N", "trimd calibrate --band")
    P = np.array([s.position_m for s in slots])
    n = len(slots)
    # x = [weight's force, float's lift (n each, ≥ 0) [N], slot used (n, 0/1), the x and
    # y moments' misses within a third of their 1σ (±, 4) and beyond it (±, 4) [N·m]]
    lever = 1.0 + np.abs(P[:, 0]) + np.abs(P[:, 1])
    cost = np.r_[lever, lever, np.full(n, _PIECE_COST), np.full(4, _MOMENT_COST),
                 np.full(4, _BEYOND_COST)]
    signed = np.kron(np.eye(2), [1.0, -1.0])         # a miss's + and − parts per axis
    lay = np.vstack([np.ones(n), P[:, 0], P[:, 1]])
    makes = np.hstack([lay, -lay, np.zeros((3, n)), np.vstack([np.zeros(4), signed]),
                       np.vstack([np.zeros(4), signed])])
    used = np.hstack([np.eye(n), np.eye(n), -np.diag(caps.max(axis=0)), np.zeros((n, 8))])
    sd = np.repeat(known[1:] / 3.0, 2)
    # W − B and the moments made (as two inequalities each), a piece only on a used slot
    A = np.vstack([makes, -makes, used])
    found = solve(cost, A, np.r_[need, -need, np.zeros(n)],
                  np.r_[caps.ravel(), np.ones(n), sd, np.full(4, np.inf)],
                  np.r_[np.zeros(2 * n), np.ones(n), np.zeros(8)].astype(int), _NODES)
    if found.x is None:          # feasible by the misses' slack: only a node limit stops it
        raise UsageError(f"no band load found ({found.message})", "trimd calibrate --band")
    x = np.asarray(found.x)
    w = x[:n] - x[n:2 * n]
    tiny = 1e-9 * max(1.0, float(np.abs(need).max()))
    pieces = tuple((s.name, float(f)) for s, f in zip(slots, w, strict=True) if abs(f) > tiny)
    miss = aim[1:] - now[1:] - P[:, :2].T @ w
    return BandLoad(pieces, (float(aim[0]), float(aim[1]), float(aim[2])),
                    (float(miss[0]), float(miss[1])))
