"""The verify hold: does the ballasted vehicle float as its proposal predicted?

After the operator has installed the ballast, one level hold (``trimd run --verify``)
measures the ballasted vehicle's net vertical force W − B and its net moments about x and
y (:func:`trimd.core.segment.estimate_segment`; at level the height of the centre of
gravity, m_z = W·z_g − B·z_b, does not show and is taken from the prediction). The
prediction is the proposal's: the trim estimate's net quantities plus what the installed
pieces add (:func:`trimd.ballast.check.check_trim`), with the estimate's covariance.

The comparison is per quantity, measured − predicted, against the σ of that difference.
The two σ are added as if independent; they are not quite (the same thrusters measured
both, so their thrust-curve errors partly cancel in the difference), which makes the
test conservative: a verdict of "not as predicted" is a real discrepancy (a wrong piece
or slot, a payload that moved, a mis-stated piece). The verdict uses the Bonferroni
quantile for the three quantities, so that a vehicle exactly as predicted passes at 95 %.
The residual passive trim is computed from the measured moments as for a proposal
(:func:`trimd.ballast.check.equilibrium_attitude`). Units: N, N·m, degrees; body FRD.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import ndtri  # scipy.stats' norm.ppf, without its 1 s import

from trimd.ballast.check import MIN_GM_M, SlotLoad, Trim, check_trim, equilibrium_attitude
from trimd.core.estimate import HoldSamples, StaticEstimate, spikes_of, with_observed_bands
from trimd.core.floating import Z95
from trimd.core.jsonsafe import json_number
from trimd.core.profile import Profile
from trimd.core.segment import SegmentEstimate, estimate_segment
from trimd.core.types import FloatArray

__all__ = ["VERIFIED", "Verification", "verification_to_dict", "verify_hold"]

#: The quantities compared, for people and JSON keys.
VERIFIED = ("net vertical force W − B [N]", "net moment W·x_g − B·x_b [N·m]",
            "net moment W·y_g − B·y_b [N·m]")
#: Two-sided 95 % quantile for three comparisons together (Bonferroni).
Z_VERDICT = float(ndtri(1 - 0.05 / 6))


@dataclass(frozen=True, eq=False)
class Verification:
    """The outcome of a verify hold (1σ throughout).

    Attributes
    ----------
    predicted : the proposal's ballasted vehicle (net moments, passive trim and its σ).
    measured : the level hold's one-segment fit (W − B, m_x, m_y measured; m_z the
        prediction's).
    difference, difference_std : measured − predicted of W − B [N], m_x, m_y [N·m].
    roll_deg, pitch_deg, roll_std_deg, pitch_std_deg : the passive trim the measured
        moments leave (NaN when the predicted vehicle has no static stability).
    level_tol_deg : the profile's level tolerance [deg].
    """

    predicted: Trim
    measured: SegmentEstimate
    difference: FloatArray
    difference_std: FloatArray
    roll_deg: float
    pitch_deg: float
    roll_std_deg: float
    pitch_std_deg: float
    level_tol_deg: float

    @property
    def z(self) -> FloatArray:
        """difference / difference_std, per quantity."""
        z: FloatArray = self.difference / self.difference_std
        return z

    @property
    def as_predicted(self) -> bool:
        """Every difference within the 95 % quantile for three comparisons."""
        return bool(np.all(np.abs(self.z) <= Z_VERDICT))

    @property
    def level(self) -> bool:
        """The measured passive trim is within the level tolerance on both axes."""
        return max(abs(self.roll_deg), abs(self.pitch_deg)) <= self.level_tol_deg

    @property
    def known_95_deg(self) -> float:
        """The half-width of the passive trim's 95 % interval on its wider axis [deg]."""
        return Z95 * max(self.roll_std_deg, self.pitch_std_deg)

    @property
    def undecided(self) -> bool:
        """Level, but the 95 % interval of the passive trim on an axis reaches beyond the
        level tolerance: the hold cannot tell level from not (on a trimmed vehicle mostly the
        thrust map at the dead bands, which a calibration narrows: docs/method.md §7)."""
        widest = self.known_95_deg
        return self.level and bool(np.isfinite(widest)) and widest > self.level_tol_deg

    @property
    def message(self) -> str:
        """One line for the operator: level or not, as predicted or not, and what differs."""
        trim = (f"passive roll {self.roll_deg:+.2f}° ± {self.roll_std_deg:.2f}°, pitch "
                f"{self.pitch_deg:+.2f}° ± {self.pitch_std_deg:.2f}° (predicted "
                f"{self.predicted.roll_deg:+.2f}°, {self.predicted.pitch_deg:+.2f}°)")
        verdict = "level" if self.level else f"NOT level within {self.level_tol_deg:g}°"
        if self.as_predicted:
            return f"{verdict}: {trim}; as predicted"
        off = [f"{name.split(' [')[0]} off by {d:+.3g} ± {s:.2g}" for name, d, s, z in
               zip(VERIFIED, self.difference, self.difference_std, self.z, strict=True)
               if abs(z) > Z_VERDICT]
        return (f"{verdict}: {trim}; NOT as predicted ({'; '.join(off)}): check what was "
                "installed, then trim again")


def verify_hold(hold: HoldSamples, profile: Profile, estimate: StaticEstimate,
                installed: Sequence[SlotLoad]) -> Verification:
    """Compare a level hold of the ballasted vehicle with the prediction for the ballast
    ``installed`` on the vehicle of ``estimate`` (module docstring).

    Raises
    ------
    EstimationError : the hold has too few samples or non-finite data.
    """
    predicted = check_trim(estimate, installed, profile.gravity_m_s2)
    q_pred = np.r_[-predicted.net_buoyancy_N, predicted.net_moment_Nm]
    # near level the thrusters idle at their bands: the edges the hold shows by hunting
    informed = with_observed_bands(spikes_of(hold, profile), profile)
    measured = estimate_segment(hold, informed, q_prior=q_pred)
    difference = measured.q[:3] - q_pred[:3]
    cov = measured.q_cov[:3, :3] + estimate.q_cov[:3, :3]
    m = np.r_[measured.q[1:3], q_pred[3]]
    attitude = equilibrium_attitude(m, MIN_GM_M * predicted.weight_N)
    if attitude is None:
        angles, std = np.full(2, math.nan), np.full(2, math.nan)
    else:
        m_cov = measured.q_cov[1:, 1:].copy()
        m_cov[2, 2] = estimate.q_cov[3, 3]
        angles, J = np.degrees(attitude[0]), attitude[1]
        std = np.degrees(np.sqrt(np.clip(np.diag(J @ m_cov @ J.T), 0.0, None)))
    return Verification(predicted, measured, difference, np.sqrt(np.diag(cov)),
                        float(angles[0]), float(angles[1]), float(std[0]), float(std[1]),
                        profile.level_tol_deg)


def verification_to_dict(v: Verification) -> dict[str, Any]:
    """JSON-ready dict of a verification (units in the key names; NaN as None)."""
    return {
        "level": v.level, "as_predicted": v.as_predicted, "message": v.message,
        "roll_deg": json_number(v.roll_deg), "pitch_deg": json_number(v.pitch_deg),
        "trim_std_deg": [json_number(v.roll_std_deg), json_number(v.pitch_std_deg)],
        "predicted_roll_deg": json_number(v.predicted.roll_deg),
        "predicted_pitch_deg": json_number(v.predicted.pitch_deg),
        "predicted_trim_std_deg": [json_number(v.predicted.roll_std_deg),
                                   json_number(v.predicted.pitch_std_deg)],
        "measured_N_Nm": [float(x) for x in v.measured.q[:3]],
        "measured_std_N_Nm": [float(x) for x in np.sqrt(np.diag(v.measured.q_cov))[:3]],
        "difference_N_Nm": [float(x) for x in v.difference],
        "difference_std_N_Nm": [float(x) for x in v.difference_std],
        "hold": {"samples": v.measured.samples,
                 "window_s": [v.measured.t_start_s, v.measured.t_end_s]},
    }
