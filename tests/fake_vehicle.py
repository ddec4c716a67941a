"""A minimal stand-in vehicle for procedure tests: first-order attitude response and the
thruster outputs that balance g(η) at the current attitude (the simulator proper lives
in drivers/sim; this one keeps procedure tests independent of it)."""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator
from dataclasses import dataclass, field

import numpy as np

from trimd.core.model import pwm_from_thrust, restoring_forces, thrust_configuration
from trimd.core.profile import Profile
from trimd.core.samples import (
    Attitude,
    Command,
    Depth,
    Health,
    HoldAttitude,
    Release,
    Sample,
    Thrusters,
)


@dataclass
class FakeVehicle:
    profile: Profile
    W: float
    r_g: np.ndarray
    seed: int = 0
    armed: bool = True
    mode: str = "ALT_HOLD"
    muted: set[str] = field(default_factory=set)  # streams that have stopped
    stuck_at_deg: float | None = None  # cannot tilt beyond this (never settles)
    depth_drift_m_s: float = 0.0
    rates_hz: dict[str, float] = field(default_factory=lambda: {
        "attitude": 20.0, "thrusters": 10.0, "depth": 5.0, "health": 1.0})
    phi: float = 0.0
    theta: float = 0.0
    target: tuple[float, float] | None = None
    depth: float = 10.0
    commands: list[tuple[float, Command]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        self.T_pinv = np.linalg.pinv(thrust_configuration(self.profile.thrusters))

    def apply(self, t: float, command: Command) -> None:
        self.commands.append((t, command))
        if isinstance(command, HoldAttitude):
            self.target = (command.phi, command.theta)
        elif isinstance(command, Release):
            self.target = None

    def samples(self, t: float, dt: float) -> list[Sample]:
        goal = self.target or (0.0, 0.0)
        if self.stuck_at_deg is not None:
            lim = math.radians(self.stuck_at_deg)
            goal = (min(goal[0], lim), min(goal[1], lim))
        k = 1 - math.exp(-dt / 2.0)
        self.phi += (goal[0] - self.phi) * k
        self.theta += (goal[1] - self.theta) * k
        self.depth += self.depth_drift_m_s * dt
        out: list[Sample] = []

        def due(stream: str) -> bool:
            if stream in self.muted:
                return False
            period = 1.0 / self.rates_hz[stream]
            return math.floor(t / period) != math.floor((t - dt) / period)

        if due("health"):
            out.append(Health(t, True, self.mode, self.armed))
        if due("thrusters"):
            tau = restoring_forces(self.phi, self.theta, self.W, self.profile.buoyancy_N,
                                   self.r_g, self.profile.r_b_m)
            f = self.T_pinv @ tau * (1 + 0.01 * self.rng.standard_normal(len(self.T_pinv)))
            pwm = tuple(float(pwm_from_thrust(th.curve, [fi], self.profile.nominal_voltage_V)[0])
                        for th, fi in zip(self.profile.thrusters, f, strict=True))
            out.append(Thrusters(t, pwm))
        if due("depth"):
            out.append(Depth(t, self.depth + 0.01 * self.rng.standard_normal()))
        if due("attitude"):
            noise = math.radians(0.05) * self.rng.standard_normal(2)
            out.append(Attitude(t, self.phi + noise[0], self.theta + noise[1], 0.3,
                                0.0, 0.0, 0.0))
        return out


class FakeLink:
    """FakeVehicle as a link in simulated time; ``hang_at``: stop sending (link lost),
    ``end_at``: the stream ends."""

    description = "fake"

    def __init__(self, vehicle: FakeVehicle, *, hang_at: float = np.inf,
                 end_at: float = np.inf) -> None:
        self.vehicle, self.hang_at, self.end_at = vehicle, hang_at, end_at
        self.t = 0.0
        self.sent: list[Command] = []
        self.closed = False

    async def samples(self) -> AsyncIterator[Sample]:
        dt = 0.01
        while self.t < self.end_at:
            self.t = round(self.t + dt, 6)
            if self.t >= self.hang_at:
                await asyncio.sleep(3600)
            for s in self.vehicle.samples(self.t, dt):
                yield s
            await asyncio.sleep(0)

    async def send(self, command: Command) -> None:
        self.sent.append(command)
        self.vehicle.apply(self.t, command)

    async def close(self) -> None:
        self.closed = True
