"""Keeping an excitation inside its envelope: how far the vehicle has gone so far, when to
scale the excitation down, when to stop early.

The guard (:class:`trimd.core.guards.Guard`) aborts an experiment the moment the vehicle
leaves the depth envelope (``--max-depth-excursion`` from the start depth) or tilts
beyond ``max_tilt_deg`` + 5°. The excitation is designed from the profile's priors, and a
vehicle whose damping, added mass or buoyancy differ from them goes further than its
design said (an unseen Sabertooth's uwq stage used to leave a 5 m envelope at 255–280 s).
:class:`Envelope` watches the excursion measured so far against each of the guard's
limits L (the depth envelope; the tilt limit with its margin, ``max_tilt_deg`` + 5°).
The design aims well inside them (a half heave doublet moves a quarter of the depth
envelope, a roll or pitch doublet half the tilt limit, the depth hold takes the drift), so
an excursion far beyond that is a vehicle the design did not foresee:

* beyond each share of L in :data:`ADAPT_SHARES` the excitation's amplitude is halved
  (:data:`SCALE_STEP`: every input's deviation from its trim offset; the holds are not
  scaled), once per share;
* beyond the share in :data:`STOP_SHARES` the experiment stops early: it ends as done,
  saying so, with every sample up to the stop recorded (``trimd identify`` fits it like
  any other), before the guard would abort it.

Depth and tilt differ in kind. A depth excursion is drift that builds up (a buoyancy or a
trim the prior does not know, heave from surge at a pitch): halving the excitation early
halves what drives it. A tilt comes back within a doublet (the attitude hold and the
restoring moment pull it level): its peaks grow with the vehicle's roll and pitch
inertia and damping, and scaling every input for one peak costs the whole stage's
excitation (an unseen BlueROV2 Heavy rolled to 20° of 30° at 78 s, and with the rest of
its uvwpqr stage at half amplitude its roll damping came out 41 % off), so tilt scales
only close to its limit.

Each step is said in words for the recording. Pure: time is the samples' own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ADAPT_SHARES", "SCALE_STEP", "STOP_EARLY", "STOP_SHARES", "Envelope", "Step"]

#: Per limit, the shares of it beyond which the excitation is scaled down, once each.
ADAPT_SHARES = {"depth": (0.65, 0.8), "tilt": (0.85,)}
#: Each scaling multiplies the excitation's amplitude by this.
SCALE_STEP = 0.5
#: Per limit, the share of it beyond which the experiment stops early.
STOP_SHARES = {"depth": 0.9, "tilt": 0.95}
#: The words that start the reason of an experiment that stopped early.
STOP_EARLY = "excitation stopped early"


@dataclass(frozen=True, slots=True)
class Step:
    """What the envelope asks for: ``stop`` early, or scale the excitation to ``scale``;
    ``text`` says why, for the recording."""

    text: str
    scale: float
    stop: bool = False


class Envelope:
    """The excursion of one experiment from its start: depth [m] against
    ``depth_limit_m``, roll and pitch [rad] against ``tilt_limit_rad``."""

    def __init__(self, depth_limit_m: float, tilt_limit_rad: float) -> None:
        self.depth_limit_m = depth_limit_m
        self.tilt_limit_rad = tilt_limit_rad
        self.scale = 1.0
        self.depth_range_m = (math.inf, -math.inf)
        self.tilt_max_rad = 0.0
        self._passed = {"depth": 0, "tilt": 0}

    def depth(self, excursion_m: float) -> Step | None:
        """A depth sample ``excursion_m`` [m] from the start depth (positive: deeper)."""
        lo, hi = self.depth_range_m
        self.depth_range_m = (min(lo, excursion_m), max(hi, excursion_m))
        return self._check("depth", abs(excursion_m), self.depth_limit_m,
                           f"depth excursion {excursion_m:+.2f} m",
                           f"±{self.depth_limit_m:g} m envelope")

    def tilt(self, phi: float, theta: float) -> Step | None:
        """An attitude sample's roll and pitch [rad]."""
        tilt = max(abs(phi), abs(theta))
        self.tilt_max_rad = max(self.tilt_max_rad, tilt)
        return self._check("tilt", tilt, self.tilt_limit_rad,
                           f"{'roll' if abs(phi) >= abs(theta) else 'pitch'} "
                           f"{math.degrees(phi if abs(phi) >= abs(theta) else theta):+.1f}°",
                           f"{math.degrees(self.tilt_limit_rad):g}° tilt envelope")

    def _check(self, key: str, value: float, limit: float, what: str, of: str
               ) -> Step | None:
        share = value / limit
        if share > STOP_SHARES[key]:
            return Step(f"{what}, {100 * share:.0f} % of the {of}", self.scale, stop=True)
        passed = sum(share > s for s in ADAPT_SHARES[key])
        if passed <= self._passed[key]:
            return None
        self.scale *= SCALE_STEP ** (passed - self._passed[key])
        self._passed[key] = passed
        return Step(f"{what}, {100 * share:.0f} % of the {of}: excitation scaled to "
                    f"{100 * self.scale:.0f} %", self.scale)

    def summary(self) -> str:
        """What the vehicle did, for the end of the recording."""
        lo, hi = self.depth_range_m
        depth = (f"depth {lo:+.2f} to {hi:+.2f} m from the start (±{self.depth_limit_m:g} m)"
                 if lo <= hi else "no depth")
        return (f"{depth}, tilt at most {math.degrees(self.tilt_max_rad):.1f}° "
                f"({math.degrees(self.tilt_limit_rad):g}°), excitation at "
                f"{100 * self.scale:.0f} %")
