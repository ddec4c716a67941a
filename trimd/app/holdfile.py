"""Read a hold CSV (``trimd solve HOLDS.csv``) into the steady samples of each hold.

Columns (header required, order free, surrounding spaces ignored):

* ``time_s``, ``roll_deg``, ``pitch_deg`` — always;
* either ``X_N, Y_N, Z_N, K_Nm, M_Nm, N_Nm`` — the generalised thruster force τ, body FRD —
  or ``pwm_<channel>`` for every thruster channel of the profile [µs], turned into τ
  through the profile's thrust curves (at ``battery_V`` when that column is present,
  else at the profile's nominal voltage);
* ``hold`` (optional integer): which hold a sample belongs to. Without it, holds are
  found by the live procedure's settling test and grouped by attitude
  (:func:`trimd.core.holdfinder.find_holds`).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from trimd.core.errors import DataError
from trimd.core.estimate import HeldOutputs, HoldSamples
from trimd.core.holdfinder import find_holds
from trimd.core.model import thrust_configuration, thrusts_from_pwm
from trimd.core.profile import Profile
from trimd.core.samples import Attitude

__all__ = ["TAU_COLUMNS", "HoldFile", "holds_from_table", "read_hold_csv"]

TAU_COLUMNS = ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm")
_BASE = ("time_s", "roll_deg", "pitch_deg")


@dataclass(frozen=True, eq=False)
class HoldFile:
    """The columns of a hold CSV as float arrays, keyed by header name."""

    path: str
    columns: dict[str, NDArray[np.float64]]


def _read_table(path: Path) -> HoldFile:
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:  # Excel writes a BOM
            rows = list(csv.reader(f))
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror})") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise DataError(f"{path}: not a CSV text file ({exc})") from None
    rows = [r for r in rows if r and not (len(r) == 1 and not r[0].strip())]
    if not rows:
        raise DataError(f"{path}: empty file (expected a header and samples)")
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        raise DataError(f"{path}: duplicate column in header {header}")
    data = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise DataError(f"{path}: line {i}: {len(row)} fields, header has {len(header)}")
        for j, cell in enumerate(row):
            try:
                value = float(cell)
            except ValueError:
                raise DataError(f"{path}: line {i}, column {header[j]}: "
                                f"not a number: {cell.strip()!r}") from None
            if not math.isfinite(value):
                raise DataError(f"{path}: line {i}, column {header[j]}: {cell.strip()} "
                                "(NaN or infinite); remove or repair that sample")
            data[i - 2, j] = value
    return HoldFile(str(path), {h: data[:, j] for j, h in enumerate(header)})


def _tau(table: HoldFile, profile: Profile
         ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, HeldOutputs | None]:
    """τ of every row, and each thruster's thrust and the outputs it was read from when τ
    comes from the PWM columns."""
    cols = table.columns
    if all(c in cols for c in TAU_COLUMNS):
        return np.column_stack([cols[c] for c in TAU_COLUMNS]), None, None
    pwm_cols = [f"pwm_{t.channel}" for t in profile.thrusters]
    if profile.thrusters and all(c in cols for c in pwm_cols):
        pwm = np.column_stack([cols[c] for c in pwm_cols])
        thrust = thrusts_from_pwm(profile, pwm, cols.get("battery_V"))
        volts = np.broadcast_to(cols.get("battery_V", profile.nominal_voltage_V),
                                (len(pwm),)).astype(float)
        return (thrust @ thrust_configuration(profile.thrusters).T, thrust,
                HeldOutputs(pwm, volts))
    missing = [c for c in TAU_COLUMNS if c not in cols]
    missing_pwm = [c for c in pwm_cols if c not in cols]
    raise DataError(f"{table.path}: missing columns: give {', '.join(missing)} "
                    f"or the profile's thruster outputs {', '.join(missing_pwm) or '(none)'}")


def holds_from_table(table: HoldFile, profile: Profile) -> list[HoldSamples]:
    """Split a table into holds (by its ``hold`` column or by steady-state detection)."""
    cols = table.columns
    missing = [c for c in _BASE if c not in cols]
    if missing:
        raise DataError(f"{table.path}: missing column(s) {', '.join(missing)}")
    t = cols["time_s"]
    if len(t) < 2:
        raise DataError(f"{table.path}: {len(t)} samples; a hold needs many more")
    if np.any(np.diff(t) < 0):
        raise DataError(f"{table.path}: time_s goes backwards at line "
                        f"{int(np.argmax(np.diff(t) < 0)) + 3}")
    phi, theta = np.radians(cols["roll_deg"]), np.radians(cols["pitch_deg"])
    tau, thrust, outputs = _tau(table, profile)

    def hold(idx: NDArray[np.intp], label: str) -> HoldSamples:
        return HoldSamples(t[idx], phi[idx], theta[idx], tau[idx], label,
                           None if thrust is None else thrust[idx],
                           None if outputs is None else outputs.take(idx))

    if "hold" in cols:
        ids = cols["hold"]
        if np.any(ids != np.round(ids)):
            raise DataError(f"{table.path}: column hold must hold whole numbers")
        return [hold(np.flatnonzero(ids == k), f"hold {int(k)}") for k in np.unique(ids)]

    # every row is a sample of each stream; body rates are not in the table
    attitude = [Attitude(float(ti), float(p), float(q), 0.0, 0.0, 0.0, 0.0)
                for ti, p, q in zip(t, phi, theta, strict=True)]
    holds = find_holds(attitude, t, tau, profile, thrust, outputs)
    if not holds:
        proc = profile.procedure
        raise DataError(f"{table.path}: no steady hold found (no stretch of at least "
                        f"{proc.min_steady_s:g} s with settled attitude and thrust, then "
                        "samples to collect); add a 'hold' column or record longer holds")
    return holds


def read_hold_csv(path: str | Path, profile: Profile) -> list[HoldSamples]:
    """Read ``path`` and return the samples of each hold; DataError on any problem."""
    return holds_from_table(_read_table(Path(path)), profile)
