"""The simulated vehicle as an in-process :class:`trimd.core.link.Link` (``--link sim[:options]``).

Simulated time is decoupled from wall time: the link steps the vehicle as fast as the
consumer takes samples, so a full trim procedure takes seconds. Every sample is stamped
with simulated time. Options: :mod:`trimd.drivers.sim.config` (``sim:payload=10@AftSB,seed=3``).

Commands: HoldAttitude holds that attitude in ALT_HOLD (depth hold continues); Release
returns to the pilot's neutral (level, same heading and depth); OpenLoop switches to
MANUAL with those axis inputs; Arm arms or disarms. The vehicle starts armed in ALT_HOLD
holding level at ``depth_m``.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

from trimd.core.errors import LinkError, ProfileError
from trimd.core.profile import Profile
from trimd.core.samples import Arm, Command, HoldAttitude, OpenLoop, Release, Sample
from trimd.drivers.limits import check_command
from trimd.drivers.sim.config import SimConfig, parse_sim_options
from trimd.drivers.sim.vehicle import SimVehicle

__all__ = ["SimLink", "open_sim_link"]


class SimLink:
    """A :class:`SimVehicle` behind the Link protocol.

    Attributes
    ----------
    vehicle : the simulated vehicle (tests read ``vehicle.truth``).
    """

    def __init__(self, vehicle: SimVehicle) -> None:
        self.vehicle = vehicle
        c = vehicle.config
        rates = {"attitude": c.attitude_hz, "thrusters": c.thrusters_hz, "depth": c.depth_hz,
                 "battery": c.battery_hz, "health": c.health_hz,
                 "velocity": c.velocity_hz if c.dvl else 0.0}
        #: steps between two samples of each kind that is produced at all
        self._every = {kind: max(1, round(1.0 / (hz * c.dt_s)))
                       for kind, hz in rates.items() if hz > 0}
        payload = c.payload or "no payload"
        self.description = f"simulated {vehicle.profile.name} ({payload}, seed {c.seed})"
        self._closed = False

    async def samples(self) -> AsyncIterator[Sample]:
        """Step the vehicle and yield each sample when it is due, until closed."""
        v = self.vehicle
        every = list(self._every.items())
        while not self._closed:
            v.step()
            due = [kind for kind, n in every if v.steps % n == 0]
            if due:
                for kind in due:
                    yield v.sample(kind)
                await asyncio.sleep(0)   # let the consumer's other tasks run

    async def send(self, command: Command) -> None:
        """Apply ``command`` at the present simulated time."""
        if self._closed:
            raise LinkError("the simulated link is closed")
        check_command(command, self.vehicle.profile)
        v = self.vehicle
        if isinstance(command, HoldAttitude):
            if v.mode != "ALT_HOLD":
                v.set_mode("ALT_HOLD")
            v.hold_attitude(command.phi, command.theta, command.psi)
        elif isinstance(command, Release):
            if v.mode != "ALT_HOLD":
                v.set_mode("ALT_HOLD")
            v.level()
        elif isinstance(command, OpenLoop):
            v.open_loop(command.axes)
        elif isinstance(command, Arm):
            v.arm(command.armed)
        else:
            raise LinkError(f"not supported by the simulated vehicle: {command!r}")

    async def close(self) -> None:
        """Stop the sample stream (idempotent)."""
        self._closed = True

    def truth(self) -> str:
        """The hidden payload and the true net weight and moments, for people (``trimd
        demo`` prints it beside the estimate); ``vehicle.truth`` has the numbers."""
        return self.vehicle.describe_truth()


def open_sim_link(options: str, profile: Profile, stream_hz: float | None = None
                  ) -> SimLink:
    """A :class:`SimLink` for ``profile`` with the options of a ``sim:`` URL;
    ``stream_hz``: the rate of attitude, thruster outputs and depth asked for (as a
    MAVLink link asks the vehicle), unless the options set those rates.

    Raises
    ------
    LinkError
        For an unknown option, a bad value or a payload the profile cannot take.
    """
    base = (SimConfig(attitude_hz=stream_hz, thrusters_hz=stream_hz, depth_hz=stream_hz)
            if stream_hz is not None else None)
    config = parse_sim_options(options, base)
    try:
        return SimLink(SimVehicle(profile, config))
    except (ProfileError, ValueError) as exc:
        raise LinkError(f"sim:{options}: {exc}") from None
