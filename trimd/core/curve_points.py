"""The PWM–thrust points of a thrust curve (:class:`~trimd.core.profile.ThrustCurve`), as
:func:`trimd.core.model.thrust_from_pwm` and :func:`~trimd.core.model.pwm_from_thrust`
interpolate them: each table's points sorted with its dead-band edges at 0 N, and a
curve's points at one battery voltage, each built once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from trimd.core.profile import ThrustCurve, ThrustTable
from trimd.core.types import FloatArray

__all__ = ["Points", "table_at", "table_points"]

Points = tuple[FloatArray, FloatArray]
#: The points of :func:`table_points` and :func:`table_at` already built, keyed by the
#: table's or curve's identity and the voltage (−1 for a table): a trim, a watch or a
#: replay reads every thruster sample through the same few curves, and sorting (and
#: hashing) a curve's tables per sample cost more than the interpolation. Each entry
#: holds its table or curve, so that no identity is reused while cached; the arrays are
#: read-only, being shared.
_POINTS: dict[tuple[int, float], tuple[object, Points]] = {}
#: Entries kept before :data:`_POINTS` starts again.
_POINTS_MAX = 512


def _cached(owner: object, voltage_V: float, build: Callable[[], Points]) -> Points:
    """``build()``'s points for ``owner`` at ``voltage_V``, built once (:data:`_POINTS`)."""
    key = (id(owner), voltage_V)
    hit = _POINTS.get(key)
    if hit is not None and hit[0] is owner:
        return hit[1]
    points = build()
    for a in points:
        a.flags.writeable = False
    if len(_POINTS) >= _POINTS_MAX:
        _POINTS.clear()
    _POINTS[key] = (owner, points)
    return points


def table_points(table: ThrustTable) -> Points:
    """PWM [µs] and thrust [N] points of one table, sorted, with its deadband edges at 0 N
    (read-only arrays)."""
    def build() -> Points:
        pwm = np.array([*table.pwm_us, *table.deadband_us])
        thrust = np.array([*table.thrust_N, 0.0, 0.0])
        order = np.argsort(pwm, kind="stable")
        return pwm[order], thrust[order]
    return _cached(table, -1.0, build)


def table_at(curve: ThrustCurve, voltage_V: float) -> Points:
    """PWM [µs] and thrust [N] points of ``curve`` at ``voltage_V`` (deadband edges = 0 N;
    read-only arrays).

    Between two tables the thrust is interpolated linearly in voltage on a common PWM
    grid; outside the tabulated voltages the nearest table is used.
    """
    return _cached(curve, voltage_V, lambda: _points_at(curve, voltage_V))


def _points_at(curve: ThrustCurve, voltage_V: float) -> Points:
    """:func:`table_at`'s points, built."""
    tables = curve.tables
    volts = [t.voltage_V for t in tables]
    if voltage_V <= volts[0]:
        return table_points(tables[0])
    if voltage_V >= volts[-1]:
        return table_points(tables[-1])
    k = int(np.searchsorted(volts, voltage_V)) - 1
    (p0, f0), (p1, f1) = table_points(tables[k]), table_points(tables[k + 1])
    w = (voltage_V - volts[k]) / (volts[k + 1] - volts[k])
    grid = np.union1d(p0, p1)
    band = (np.array(tables[k].deadband_us) * (1 - w)
            + np.array(tables[k + 1].deadband_us) * w)
    thrust = np.interp(grid, p0, f0) * (1 - w) + np.interp(grid, p1, f1) * w
    inside = (grid >= band[0]) & (grid <= band[1])  # zero thrust in the closed band
    grid = np.concatenate([grid[~inside], band])
    thrust = np.concatenate([thrust[~inside], [0.0, 0.0]])
    order = np.argsort(grid, kind="stable")
    return grid[order], thrust[order]
