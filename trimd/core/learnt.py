"""What a calibration learnt, for people (docs/method.md §7): each thruster's gain errors
forward and reverse [%] and its ESC's dead-band edge offsets [µs], posterior and prior,
and whether the data narrowed each (:data:`DETERMINED`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from trimd.core.curve_error import error_scales
from trimd.core.map_posterior import ThrustMapPosterior
from trimd.core.profile import Profile
from trimd.core.types import JsonObject

__all__ = ["DETERMINED", "BandEdge", "Gain", "band_edge_to_dict", "band_edges", "gain_to_dict",
           "gains"]

#: A parameter counts as determined by the data when its posterior σ is below this share
#: of its prior σ.
DETERMINED = 0.9


@dataclass(frozen=True)
class Gain:
    """One thruster's relative gain error in one direction [%], 1σ, prior and posterior."""

    thruster: str
    direction: str
    mean_pct: float
    std_pct: float
    prior_std_pct: float

    @property
    def determined(self) -> bool:
        """The data narrowed it (posterior σ below :data:`DETERMINED` of the prior)."""
        return self.std_pct < DETERMINED * self.prior_std_pct


@dataclass(frozen=True)
class BandEdge:
    """One edge ("low" or "high") of a thruster's ESC dead band: its offset from the
    profile's [µs; positive: later in PWM], 1σ, prior and posterior."""

    thruster: str
    edge: str
    mean_us: float
    std_us: float
    prior_std_us: float

    @property
    def determined(self) -> bool:
        """The data narrowed it (posterior σ below :data:`DETERMINED` of the prior)."""
        return self.std_us < DETERMINED * self.prior_std_us


def gains(post: ThrustMapPosterior, profile: Profile) -> list[Gain]:
    """Each thruster's gain error forward and reverse under ``post`` (true thrust =
    (1 + gain)·the profile curve's)."""
    n, out = len(profile.thrusters), []
    pct = 100 * error_scales(profile)[0]
    for d, direction in enumerate(("forward", "reverse")):
        for i, t in enumerate(profile.thrusters):
            k, s = d * n + i, float(pct[i])
            out.append(Gain(t.name, direction, float(post.mean[k]) * s,
                            math.sqrt(float(post.cov[k, k])) * s, s))
    return out


def band_edges(post: ThrustMapPosterior, profile: Profile) -> list[BandEdge]:
    """Each thruster's dead-band edge offsets, low then high, under ``post``."""
    n, out = len(profile.thrusters), []
    band_us = error_scales(profile)[1]
    for d, edge in enumerate(("low", "high")):
        for i, t in enumerate(profile.thrusters):
            k, s = (2 + d) * n + i, float(band_us[i])
            out.append(BandEdge(t.name, edge, float(post.mean[k]) * s,
                                math.sqrt(float(post.cov[k, k])) * s, s))
    return out


def gain_to_dict(g: Gain) -> JsonObject:
    """JSON-ready dict of a gain (units in the key names)."""
    return {"thruster": g.thruster, "direction": g.direction, "mean_pct": g.mean_pct,
            "std_pct": g.std_pct, "prior_std_pct": g.prior_std_pct,
            "determined": g.determined}


def band_edge_to_dict(b: BandEdge) -> JsonObject:
    """JSON-ready dict of a band edge's offset (units in the key names)."""
    return {"thruster": b.thruster, "edge": b.edge, "mean_us": b.mean_us, "std_us": b.std_us,
            "prior_std_us": b.prior_std_us, "determined": b.determined}
