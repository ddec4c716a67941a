"""What many tests share: where things are, true payloads, synthetic equilibrium holds, a
minimal stand-in vehicle and link, the physics check of a proposal (applied to the
simulated vehicle, it must leave it level with thrusters off), and a full trim of the
simulated vehicle with its truth beside the result (:func:`sim_trim`).

The stand-in vehicle has a first-order attitude response and the thruster outputs that
balance g(η) at its current attitude; it keeps procedure tests independent of the
simulator proper (``trimd/drivers/sim``).
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.signal import lfilter

from tests.shared_runs import shared_run
from trimd.app.connect import open_link
from trimd.app.float_check import FloatRequest, float_session
from trimd.app.session import Session, SessionResult
from trimd.ballast.check import SlotLoad
from trimd.ballast.propose import Proposal, proposal_to_dict, propose_ballast
from trimd.ballast.verify import verify_hold
from trimd.core.calibration import (
    CalibrationHold,
    Experiment,
    FloatReference,
    calibration_hold,
    installed_change,
)
from trimd.core.estimate import HoldSamples, StaticEstimate
from trimd.core.events import Phase
from trimd.core.float_reference import float_reference
from trimd.core.floating import FloatResult
from trimd.core.model import pwm_from_thrust, restoring_forces, thrust_configuration
from trimd.core.procedure import Procedure
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
from trimd.drivers.mavlink.ardusub import mode_class_of
from trimd.drivers.sim.config import SimConfig, with_presets
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.truth import implied_mass, passive_trim_deg
from trimd.drivers.sim.vehicle import SimVehicle

REPO = Path(__file__).resolve().parent.parent
PROFILES = REPO / "trimd" / "profiles"  # the shipped profiles (package data)
ARDUSUB_LOGS = REPO / "tests" / "data" / "ardusub"  # real logs, MIT: see SOURCES.md there


def payload_truth(profile: Profile, m_ext: float, r_ext: np.ndarray) -> tuple[float, np.ndarray]:
    """Weight [N] and centre of gravity [m] of the vehicle plus a point mass (CG0 = 0)."""
    W = (profile.mass_kg + m_ext) * profile.gravity_m_s2
    return W, m_ext * np.asarray(r_ext, float) / (profile.mass_kg + m_ext)


def equilibrium_holds(profile: Profile, W: float, r_g: np.ndarray, *, n: int = 200,
                      attitude_noise_deg: float = 0.0, thrust_noise: float | np.ndarray = 0.0,
                      wander_deg: float = 0.0, wander_tau_s: float = 5.0,
                      thruster_every: int = 1, rate_hz: float = 10.0,
                      rng: np.random.Generator | None = None,
                      tilts_deg: tuple[tuple[float, float], ...] = ((0, 0), (20, 20)),
                      ) -> list[HoldSamples]:
    """Steady holds where τ = g(η) at the true attitude, plus optional noise.

    Attitude noise [deg] (white) and wander [deg] (first-order Gauss–Markov with
    correlation time ``wander_tau_s`` [s], the error of an attitude estimate at rest)
    corrupt the measured roll/pitch; thrust noise is a fraction of the largest force
    (force rows) or moment (moment rows) of the hold, one per row when an array. The
    thruster outputs are sampled every ``thruster_every``-th attitude sample and held
    (zero-order hold), as a link at a lower thruster rate delivers them.
    """
    rng = rng or np.random.default_rng(0)
    rho = np.exp(-1 / (wander_tau_s * rate_hz))
    holds = []
    for k, (roll, pitch) in enumerate(tilts_deg):
        phi, theta = np.radians(roll), np.radians(pitch)
        tau = restoring_forces(phi, theta, W, profile.buoyancy_N, r_g, profile.r_b_m)
        scale = np.r_[np.full(3, np.abs(tau[:3]).max()), np.full(3, np.abs(tau[3:]).max())]
        noise_att = np.radians(attitude_noise_deg) * rng.standard_normal((n, 2))
        drive = np.radians(wander_deg) * np.sqrt(1 - rho**2) * rng.standard_normal((n, 2))
        drive[0] = np.radians(wander_deg) * rng.standard_normal(2)
        noise_att += lfilter([1.0], [1.0, -rho], drive, axis=0)
        taus = tau + np.asarray(thrust_noise) * scale * rng.standard_normal((n, 6))
        taus = taus[np.arange(n) // thruster_every * thruster_every]
        holds.append(HoldSamples(np.arange(n) / rate_hz + 1000.0 * k, phi + noise_att[:, 0],
                                 theta + noise_att[:, 1], taus, f"hold {k}"))
    return holds


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
    yaw_rate_rad_s: float = 0.0  # the heading turns at this rate, whatever is commanded
    rates_hz: dict[str, float] = field(default_factory=lambda: {
        "attitude": 20.0, "thrusters": 10.0, "depth": 5.0, "health": 1.0})
    phi: float = 0.0
    theta: float = 0.0
    target: tuple[float, float] | None = None
    depth: float = 10.0
    commands: list[tuple[float, Command]] = field(default_factory=list)
    last_sent: dict[str, float] = field(default_factory=dict)  # stream → time of its last sample

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
            if math.floor(t / period) == math.floor((t - dt) / period):
                return False
            self.last_sent[stream] = t
            return True

        if due("health"):
            out.append(Health(t, True, self.mode, self.armed,
                              mode_class=mode_class_of(self.mode)))
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
            out.append(Attitude(t, self.phi + noise[0], self.theta + noise[1],
                                0.3 + self.yaw_rate_rad_s * t, 0.0, 0.0, self.yaw_rate_rad_s))
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


def ballast_payload(proposal: Proposal | dict[str, Any], profile: Profile) -> str:
    """The proposal (or its JSON) as simulator payload items: net kg down at each slot
    (negative: lift)."""
    slots = (proposal_to_dict(proposal) if isinstance(proposal, Proposal) else proposal)["slots"]
    return "+".join(f"{s['net_down_N'] / profile.gravity_m_s2:.6f}@{s['name']}" for s in slots
                    if abs(s["net_down_N"]) > 0)


def carried(loads: Sequence[SlotLoad], g: float) -> str:
    """``loads`` as simulator payload items at their positions (kg down; negative: lift):
    the ballast a verify hold checks, fitted on the simulated vehicle."""
    return "+".join(f"{ld.net_down_N / g:.6f}@{ld.position_m[0]},{ld.position_m[1]},"
                    f"{ld.position_m[2]}" for ld in loads if ld.net_down_N)


@shared_run
def passive_attitude_deg(profile: Profile, payload: str, config: SimConfig | None = None
                         ) -> np.ndarray:
    """Mean roll and pitch [deg] of the simulated vehicle, disarmed, after settling.

    ``config`` (e.g. the trimmed vehicle's, with ``truth=perturbed``) gives the true
    vehicle: its seed and profile errors are kept; noise and disturbances are off. Made
    once per test run for the same arguments (180 s of simulated time, ≈ 2 s of CPU): the
    payload before a trim's ballast, and often after it, is the same in several tests."""
    base = with_presets(config or SimConfig(), disturb="none")
    vehicle = SimVehicle(profile, replace(base, payload=payload, armed=False, mode="MANUAL",
                                          noise=0.0, depth_m=20.0))
    vehicle.run_for(150.0)
    angles = []
    for _ in range(300):
        vehicle.run_for(0.1)
        angles.append(vehicle.truth.eta[3:5])
    return np.degrees(np.mean(angles, axis=0))


def assert_proposal_levels(profile: Profile, payload: str, proposal: Proposal | dict[str, Any],
                           config: SimConfig | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Apply ``proposal`` to the simulated vehicle carrying ``payload`` (the true vehicle of
    ``config``, see :func:`passive_attitude_deg`), thrusters off: on each axis it must float
    within the profile's level tolerance or within the proposal's own predicted trim ± its
    95 % interval, whichever is larger, and never beyond 1°. Returns roll and pitch [deg]
    before and after."""
    d = proposal_to_dict(proposal) if isinstance(proposal, Proposal) else proposal
    predicted = np.array([d["predicted_roll_deg"], d["predicted_pitch_deg"]], dtype=float)
    sigma = np.array(d["predicted_trim_std_deg"], dtype=float)
    before = passive_attitude_deg(profile, payload, config)
    after = passive_attitude_deg(profile, payload + "+" + ballast_payload(proposal, profile),
                                 config)
    as_said = (np.abs(after) <= profile.level_tol_deg) | (np.abs(after - predicted) <= 1.96 * sigma)
    assert np.all(as_said) and np.all(np.abs(after) < 1.0), (before, after, predicted, sigma)
    return before, after


@dataclass(frozen=True)
class SimTrim:
    """One full trim of the simulated vehicle: what trimd concluded, and the truth.

    Attributes
    ----------
    result : how the session ended, its estimate and proposal.
    vehicle : the simulated vehicle at the end (``vehicle.truth.mass.net`` is the TRUE
        q = [W − B, W·r_g − B·r_b] [N, N·m]; ``vehicle.t_s`` the simulated time the trim
        took [s]).
    """

    result: SessionResult
    vehicle: SimVehicle

    @property
    def q_true(self) -> np.ndarray:
        """The true net weight and moments q [N, N·m] (body FRD, origin CG0)."""
        return self.vehicle.truth.mass.net

    @property
    def implied_truth(self) -> tuple[float, np.ndarray]:
        """m_ext [kg] and r_g [m] an exact estimate of the true q reports through the
        nominal profile (``trimd.drivers.sim.truth.implied_mass``): what to compare the
        estimate's m_ext and r_g with when the vehicle differs from its profile."""
        return implied_mass(self.vehicle.profile, self.q_true)

    def trim_after_proposal_deg(self) -> tuple[float, float]:
        """Roll and pitch [deg] at which the TRUE vehicle floats, thrusters off, once the
        session's proposal is put on it."""
        assert self.result.proposal is not None, self.result.reason
        extra = ballast_payload(self.result.proposal, self.vehicle.profile)  # type: ignore[arg-type]
        return passive_trim_deg(self.vehicle.ballasted(extra).net)


@shared_run
def sim_trim(profile: Profile, payload: str, seed: int, options: str = "",
             method: str = "milp",
             estimate_with: Callable[[SimVehicle], Profile] | None = None) -> SimTrim:
    """Run the whole trim procedure, headless and confirmed, on the in-process simulated
    vehicle ``sim:payload=PAYLOAD,seed=SEED,OPTIONS`` (e.g. ``options="disturb=real,
    truth=perturbed"``), proposing ballast by ``method``. Time is the simulator's alone
    (no wall-clock Ticks), so a seed gives the same result every time. The simulator is
    built from ``profile``; trimd estimates with it too, or with ``estimate_with(vehicle)``
    (a profile that knows some of the simulated vehicle's truth)."""
    async def go() -> SimTrim:
        url = f"sim:payload={payload},seed={seed}" + (f",{options}" if options else "")
        link = await open_link(url, profile)
        assert isinstance(link, SimLink)
        used = profile if estimate_with is None else estimate_with(link.vehicle)
        session = Session(link, used, recorder=None, presenters=[], confirmed=True,
                          propose=lambda est: propose_ballast(est, used, method=method),
                          wall_clock=False)
        try:
            return SimTrim(await session.run(), link.vehicle)
        finally:
            await link.close()
    return asyncio.run(go())


@dataclass(frozen=True)
class SimVerify:
    """One verify hold on the simulated vehicle: the session's result (``verification``
    when it ended DONE) and the simulated time it took [s] (the dive's, from the start)."""

    result: SessionResult
    t_s: float


@shared_run
def sim_verify(profile: Profile, payload: str, seed: int, options: str,
               estimate: StaticEstimate, installed: Sequence[SlotLoad],
               on_vehicle: Sequence[SlotLoad] | None = None) -> SimVerify:
    """The verify hold (:func:`trimd.ballast.verify.verify_hold`) of the trim ``estimate``
    with the ballast ``installed`` since (per slot, what changed), headless and confirmed,
    on the in-process simulated vehicle ``sim:payload=PAYLOAD+ON_VEHICLE,seed=SEED,
    OPTIONS`` (``on_vehicle`` default: ``installed``, fitted at their positions:
    :func:`carried`). Same seed, same true vehicle as the trim's."""
    extra = carried(installed if on_vehicle is None else on_vehicle, profile.gravity_m_s2)

    async def go() -> SimVerify:
        url = f"sim:payload={'+'.join(filter(None, (payload, extra)))},seed={seed}" + (
            f",{options}" if options else "")
        link = await open_link(url, profile)
        assert isinstance(link, SimLink)
        procedure = Procedure(profile, confirmed=True,
                              verify=lambda hold: verify_hold(hold, profile, estimate, installed))
        try:
            result = await Session(link, profile, recorder=None, presenters=[],
                                   procedure=procedure, wall_clock=False).run()
            return SimVerify(result, link.vehicle.t_s)
        finally:
            await link.close()
    return asyncio.run(go())


@shared_run
def sim_level_hold(profile: Profile, payload: str, seed: int, options: str) -> HoldSamples:
    """One level hold of the in-process simulated vehicle
    ``sim:payload=PAYLOAD,seed=SEED,OPTIONS`` (a verify hold's procedure), its samples."""
    async def go() -> HoldSamples:
        link = await open_link(f"sim:payload={payload},seed={seed},{options}", profile)
        procedure = Procedure(profile, confirmed=True, verify=lambda hold: hold)
        try:
            result = await Session(link, profile, recorder=None, presenters=[],
                                   procedure=procedure, wall_clock=False).run()
        finally:
            await link.close()
        assert result.phase is Phase.DONE, result.reason
        assert isinstance(result.verification, HoldSamples)
        return result.verification
    return asyncio.run(go())


@dataclass(frozen=True)
class SimFloat:
    """One float check on the simulated vehicle: the session's result, the TRUE passive
    roll and pitch of the vehicle it floated [deg] and the simulated time it took [s]
    (the dive's, from the start)."""

    result: SessionResult
    truth_deg: tuple[float, float]
    t_s: float

    @property
    def floated(self) -> FloatResult | None:
        """The float's result; None when it gave none (``result.reason`` says why)."""
        r = self.result.verification
        return r if isinstance(r, FloatResult) else None


@shared_run
def sim_float(profile: Profile, payload: str, seed: int, options: str,
              depth_excursion_m: float | None = None, for_correction: bool = False
              ) -> SimFloat:
    """The float check (:class:`trimd.core.float_check.FloatCheck`), confirmed, on the
    in-process simulated vehicle ``sim:payload=PAYLOAD,seed=SEED,OPTIONS`` in a depth
    envelope of ``depth_excursion_m`` [m] (default: the profile's), ``for_correction`` as
    the check takes it. Same seed, same true vehicle as the trim's."""
    async def go() -> SimFloat:
        url = f"sim:payload={payload},seed={seed}" + (f",{options}" if options else "")
        link = await open_link(url, profile)
        assert isinstance(link, SimLink)
        session = float_session(link, profile, [], FloatRequest(
            profile.name, confirmed=True, depth_excursion_m=depth_excursion_m,
            for_correction=for_correction),
            wall_clock=False)
        try:
            result = await session.run()
            return SimFloat(result, passive_trim_deg(link.vehicle.truth.mass.net),
                            link.vehicle.t_s)
        finally:
            await link.close()
    return asyncio.run(go())


@dataclass(frozen=True)
class SimReference:
    """:func:`sim_float_reference`'s: the reference (None when there is none, ``reason``
    says why), the ballasted payload and the TRUE q of that vehicle [N, N·m]."""

    reference: FloatReference | None
    reason: str = ""
    payload: str = ""
    q_true: np.ndarray = field(default_factory=lambda: np.zeros(4))


def sim_float_reference(trim: SimTrim, payload: str, hold_seed: int, float_seed: int,
                        options: str, depth_excursion_m: float | None = None
                        ) -> SimReference:
    """The use case after ``trim`` (of ``payload``): fit its proposal's ballast, hold the
    vehicle level, then float it (:class:`trimd.core.float_reference.FloatReference`; the
    dives ``sim:…,seed=HOLD_SEED,OPTIONS`` and ``…FLOAT_SEED…``: give ``truth_seed`` in
    ``options`` to keep the trim's vehicle). q_z is the trim's estimate moved by the
    ballast's weights at their slots' depths; the float's depth envelope
    ``depth_excursion_m`` [m] (default: the profile's)."""
    profile = trim.vehicle.profile
    est, proposal = trim.result.estimate, trim.result.proposal
    if est is None or not isinstance(proposal, Proposal):
        return SimReference(None, f"no proposal: {trim.result.reason}")
    extra = ballast_payload(proposal, profile)
    ballasted = f"{payload}+{extra}" if extra else payload
    floated = sim_float(profile, ballasted, float_seed, options, depth_excursion_m)
    f = floated.floated
    if f is None:
        return SimReference(None, f"no float: {floated.result.reason}")
    added = sum((s["net_down_N"] * np.r_[1.0, profile.slot(s["name"]).position_m]
                 for s in proposal_to_dict(proposal)["slots"]), np.zeros(4))
    hold = calibration_hold(sim_level_hold(profile, ballasted, hold_seed, options), profile,
                            est.q + added)
    return SimReference(float_reference("level hold → float", hold, f,
                                        float(est.q[3] + added[3]), float(est.q_cov[3, 3])),
                        payload=ballasted, q_true=trim.vehicle.ballasted(extra).net)


def sim_apply_experiment(trim: SimTrim, payload: str, after: CalibrationHold, seed: int,
                         options: str) -> Experiment:
    """The calibration experiment of the loop's trim → apply → verify: ``trim``'s
    proposal (of ``payload``) fitted between a level hold of the vehicle as trimmed and
    ``after``, the ballasted vehicle's. The first hold is not the trim's own but one on the
    dive ``sim:payload=PAYLOAD,seed=SEED,OPTIONS``: a bench that trims the trim's dive again
    must not learn that dive's noise."""
    profile = trim.vehicle.profile
    est, proposal = trim.result.estimate, trim.result.proposal
    assert est is not None and isinstance(proposal, Proposal), trim.result.reason
    before = calibration_hold(sim_level_hold(profile, payload, seed, options), profile, est.q)
    return Experiment("trim level hold → apply → level hold", before, after,
                      installed_change(proposal.installed, proposal.installed_after),
                      est.q, est.q_cov)


def command_plan(sent: Sequence[Command]) -> list[tuple[float, float] | str]:
    """The commands a session sent, as its plan: each held (roll, pitch) [deg, rounded to
    0.01°] once, however often the held heading was moved along during the hold
    (``trimd.core.procedure.HEADING_LEASH_DEG``), and ``"release"``. The steps of a ramp
    to a hold (``trimd.core.ramp``) are left out: an attitude is held when the next
    command holds it too (the next hold's ramp starts there) or is not an attitude."""
    steps = [(round(math.degrees(c.phi), 2), round(math.degrees(c.theta), 2))
             if isinstance(c, HoldAttitude) else type(c).__name__.lower() for c in sent]
    plan: list[tuple[float, float] | str] = []
    for k, step in enumerate(steps):
        after = steps[k + 1] if k + 1 < len(steps) else "end"
        held = isinstance(step, str) or isinstance(after, str) or after == step
        if held and (not plan or plan[-1] != step):
            plan.append(step)
    return plan
