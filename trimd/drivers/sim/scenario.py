"""What happens to the simulated vehicle during a dive: a leak, a lost ballast piece, a pilot.

Three ``sim:`` options (:class:`~trimd.drivers.sim.config.SimConfig`) script an ordinary
dive for the passive watch (``trimd watch``), with nobody commanding through the link:

* ``leak_N_min=0.5,leak_start_s=300`` — water comes in at 0.5 N of weight per minute
  from 300 s of simulated time on, at ``leak_at`` (a slot name or ``x,y,z`` in metres,
  body FRD; default the origin CG0). The housing's volume does not change, so the weight
  adds to W alone. ``leak_max_N=4`` stops it once 4 N are in (a flooded housing is
  full): at ``leak_N_min=60`` that is a step of 4 N within 4 s.
* ``drop=PIECE@SLOT@T_S`` — at ``T_S`` [s] a ballast piece of the profile's inventory
  (``lead-200g``; or a mass in kg, ``0.2``) falls off ``SLOT``: its in-water weight (a
  float's lift) is taken from the vehicle there. Several drops join with ``+``:
  ``drop=lead-200g@W-aft-ctr@600+foam@F-front-port@900``.
* ``pilot=dive`` — a scripted pilot flies the sticks as ArduSub's pilot input does in
  ALT_HOLD (surge and sway to the thrusters, throttle moves the depth target, yaw the
  heading target): a hover, a transit, a turn, a descent, a sideways move and an ascent,
  each followed by a hover, repeated (:data:`DIVE`, one cycle ≈ 10 min).
* ``pilot=transits`` — a pilot driving the usual way in ALT_HOLD: every minute a 20 s
  transit forward (stick 35 %) ending in a turn of ≈ 55°, alternately to starboard and
  to port, then 40 s stopped (:data:`TRANSITS`). The pilot moves each stick over
  :data:`TRANSITS_RAMP_S` (so the sticks are at rest for the last 36 s of each stop),
  and with an ArduSub-like attitude loop (``attitude_bandwidth_rad_s=6``) the vehicle
  stays level throughout, within ≈ 1.5°: attitude and depth do not tell transit from
  stop, only the effort, the speed and the heading do.

Neither script's sticks reach the link's telemetry (as a router passes a ground
station's MANUAL_CONTROL to the vehicle only).

The weight changes are applied once per simulated second (a leak of 0.5 N/min steps by
0.008 N), through the vehicle's mass properties (:mod:`trimd.drivers.sim.payload`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from trimd.core.errors import ProfileError
from trimd.core.profile import Profile
from trimd.drivers.sim.payload import PayloadItem, parse_payload

__all__ = ["DIVE", "PILOT_SCRIPTS", "TRANSITS", "TRANSITS_RAMP_S", "Drop", "PilotScript",
           "Scenario", "parse_drops"]

Sticks = tuple[float, float, float, float]
#: The ``dive`` script: (duration [s], sticks (surge, sway, throttle up, yaw rate)).
DIVE: tuple[tuple[float, Sticks], ...] = (
    (90.0, (0.0, 0.0, 0.0, 0.0)),     # hover
    (40.0, (0.4, 0.0, 0.0, 0.0)),     # transit forward
    (90.0, (0.0, 0.0, 0.0, 0.0)),
    (5.0, (0.0, 0.0, 0.0, 0.3)),      # turn ≈ 70° to starboard
    (90.0, (0.0, 0.0, 0.0, 0.0)),
    (8.0, (0.0, 0.0, -0.3, 0.0)),     # descend 1.2 m
    (90.0, (0.0, 0.0, 0.0, 0.0)),
    (20.0, (0.0, 0.4, 0.0, 0.0)),     # move to starboard
    (90.0, (0.0, 0.0, 0.0, 0.0)),
    (8.0, (0.0, 0.0, 0.3, 0.0)),      # ascend 1.2 m
    (60.0, (0.0, 0.0, 0.0, 0.0)),
)
#: The ``transits`` script (two minutes, repeated): transit with a turn at its end, stop.
TRANSITS: tuple[tuple[float, Sticks], ...] = (
    (16.0, (0.35, 0.0, 0.0, 0.0)),    # transit forward
    (4.0, (0.35, 0.0, 0.0, 0.3)),     # … turning to starboard at its end
    (40.0, (0.0, 0.0, 0.0, 0.0)),     # stopped
    (16.0, (0.35, 0.0, 0.0, 0.0)),
    (4.0, (0.35, 0.0, 0.0, -0.3)),    # … to port
    (40.0, (0.0, 0.0, 0.0, 0.0)),
)
#: Each stick of the ``transits`` pilot moves to its new position over this long [s].
TRANSITS_RAMP_S = 4.0


@dataclass(frozen=True, slots=True)
class PilotScript:
    """The sticks of a scripted pilot: each step (duration [s], sticks) in turn, repeated;
    at the start of each step the sticks move linearly from the step before over
    ``ramp_s`` [s] (0: at once; the first step starts from neutral)."""

    steps: tuple[tuple[float, Sticks], ...]
    ramp_s: float = 0.0

    def sticks(self, t_s: float) -> Sticks:
        period = sum(d for d, _ in self.steps)
        t = math.fmod(t_s, period)
        before: Sticks = self.steps[-1][1] if t_s >= period else (0.0, 0.0, 0.0, 0.0)
        for duration, sticks in self.steps:
            if t < duration:
                if t >= self.ramp_s:
                    return sticks
                w = t / self.ramp_s
                a, b, c, d = (x + w * (y - x) for x, y in zip(before, sticks, strict=True))
                return (a, b, c, d)
            t -= duration
            before = sticks
        return self.steps[-1][1]


PILOT_SCRIPTS = {"dive": PilotScript(DIVE), "transits": PilotScript(TRANSITS, TRANSITS_RAMP_S)}


@dataclass(frozen=True, slots=True)
class Drop:
    """A piece lost at ``t_s`` [s]: ``weight_N`` its in-water weight (negative: a float's
    lift) at ``position_m`` (body FRD), ``label`` as written."""

    t_s: float
    weight_N: float
    position_m: tuple[float, float, float]
    label: str


def parse_drops(text: str, profile: Profile) -> tuple[Drop, ...]:
    """Parse ``PIECE@SLOT@T_S[+…]`` (module docstring).

    Raises
    ------
    ProfileError : malformed, or a piece or slot the profile does not have.

    Examples
    --------
    >>> from trimd.core.profile_yaml import load_profile
    >>> d = parse_drops("0.5@W-aft-ctr@600", load_profile("bluerov2-heavy"))[0]
    >>> d.t_s, round(d.weight_N, 3)
    (600.0, 4.905)
    """
    out = []
    for part in filter(None, (p.strip() for p in text.split("+"))):
        fields = part.split("@")
        if len(fields) != 3:
            raise ProfileError(f"drop '{part}': expected PIECE@SLOT@T_S "
                               "(e.g. lead-200g@W-aft-ctr@600)")
        piece, slot, when = fields
        try:
            t_s = float(when)
        except ValueError:
            raise ProfileError(f"drop '{part}': the time {when!r} is not a number of "
                               "seconds") from None
        out.append(Drop(t_s, _in_water_weight(piece, profile, part),
                        profile.slot(slot).position_m, part))
    return tuple(out)


def _in_water_weight(piece: str, profile: Profile, part: str) -> float:
    g, rho = profile.gravity_m_s2, profile.water_density_kg_m3
    for p in profile.inventory:
        if p.name.lower() == piece.lower():
            return p.mass_kg * g - rho * g * p.volume_m3
    try:
        kg = float(piece)
    except ValueError:
        names = ", ".join(p.name for p in profile.inventory) or "none"
        raise ProfileError(f"drop '{part}': no piece '{piece}' in the inventory ({names}); "
                           "or give its mass in kg") from None
    return kg * g


class Scenario:
    """The leak, drops and pilot of one :class:`~trimd.drivers.sim.config.SimConfig`."""

    def __init__(self, profile: Profile, leak_N_min: float, leak_start_s: float,
                 leak_at: str, drop: str, pilot: str, leak_max_N: float = 0.0) -> None:
        if leak_N_min < 0 or leak_max_N < 0:
            raise ProfileError(f"leak_N_min={leak_N_min:g}, leak_max_N={leak_max_N:g}: a "
                               "leak adds weight (≥ 0)")
        self.leak_N_s = leak_N_min / 60
        self.leak_start_s = leak_start_s
        self.leak_max_N = leak_max_N or math.inf
        where = parse_payload(f"1@{leak_at}", profile)[0].position_m if leak_at else (
            0.0, 0.0, 0.0)
        self.leak_at = where
        self.drops = parse_drops(drop, profile)
        if pilot and pilot not in PILOT_SCRIPTS:
            raise ProfileError(f"pilot={pilot}: known scripts: {', '.join(PILOT_SCRIPTS)}")
        self.script = PILOT_SCRIPTS.get(pilot)
        self._g = profile.gravity_m_s2

    @property
    def changes_mass(self) -> bool:
        return bool(self.leak_N_s or self.drops)

    def leaked_N(self, t_s: float) -> float:
        """Weight of the water in at ``t_s`` [N]."""
        return min(self.leak_max_N, self.leak_N_s * max(0.0, t_s - self.leak_start_s))

    def payload(self, t_s: float) -> tuple[PayloadItem, ...]:
        """What the scenario adds to the hidden payload at ``t_s``: the water (a weight),
        each lost piece (its weight taken away as a lift, a lost float as a weight)."""
        items = []
        water = self.leaked_N(t_s)
        if water > 0:
            items.append(PayloadItem(water / self._g, self.leak_at, "leak"))
        items += [PayloadItem(-d.weight_N / self._g, d.position_m, f"lost {d.label}")
                  for d in self.drops if t_s >= d.t_s]
        return tuple(items)

    def sticks(self, t_s: float) -> Sticks | None:
        """The scripted pilot's sticks at ``t_s`` (None: no script)."""
        return None if self.script is None else self.script.sticks(t_s)
