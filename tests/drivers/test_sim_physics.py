"""Physics of the simulated vehicle against analytic answers (drivers/sim)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import fsolve

from bench.bench_sim import numpy_derivative
from tests.helpers import payload_truth
from trimd.core.errors import ProfileError
from trimd.core.model import restoring_forces, tau_from_pwm
from trimd.core.profile import Profile
from trimd.drivers.sim.config import SimConfig
from trimd.drivers.sim.dynamics import RigidBody, initial_state
from trimd.drivers.sim.payload import mass_properties, parse_payload
from trimd.drivers.sim.vehicle import SimVehicle

QUIET = SimConfig(noise=0.0)


def test_payload_syntax(sabertooth: Profile) -> None:
    items = parse_payload("10@aftsb+3.5@0.2,-0.1,0.05+-2@FrontP", sabertooth)
    assert [i.mass_kg for i in items] == [10.0, 3.5, -2.0]
    assert items[0].position_m == sabertooth.slot("AftSB").position_m
    assert items[1].position_m == (0.2, -0.1, 0.05)
    assert parse_payload("", sabertooth) == ()
    for bad in ("10", "10@Nowhere", "x@AftSB", "0@AftSB", "1@0.1,0.2"):
        with pytest.raises(ProfileError):
            parse_payload(bad, sabertooth)


def test_mass_properties_weight_and_float(sabertooth: Profile) -> None:
    slot = np.array(sabertooth.slot("AftSB").position_m)
    W, r_g = payload_truth(sabertooth, 10.0, slot)
    mp = mass_properties(sabertooth, parse_payload("10@AftSB", sabertooth))
    np.testing.assert_allclose([mp.W, *mp.r_g], [W, *r_g], rtol=1e-12)
    lift = 2.0 * sabertooth.gravity_m_s2
    f = mass_properties(sabertooth, parse_payload("-2@AftSB", sabertooth))
    np.testing.assert_allclose(f.W, sabertooth.weight_N)
    np.testing.assert_allclose(f.net, [sabertooth.weight_N - sabertooth.buoyancy_N - lift,
                                       *(-sabertooth.buoyancy_N * np.array(sabertooth.r_b_m)
                                         - lift * slot)], rtol=1e-12)


def test_scalar_dynamics_equal_numpy_reference(bluerov: Profile) -> None:
    rng = np.random.default_rng(1)
    body = RigidBody(bluerov, mass_properties(bluerov, parse_payload("0.4@0.1,-0.05,0.17",
                                                                     bluerov)))
    hydro = (np.array(bluerov.added_mass), np.array(bluerov.linear_damping),
             np.array(bluerov.quadratic_damping))
    for _ in range(20):
        x = np.array(initial_state(*rng.uniform(-1, 1, 4), rng.uniform(-0.5, 0.5, 6)))
        tau, v_c = rng.normal(0, 5, 6), np.r_[rng.normal(0, 0.2, 2), 0.0]
        np.testing.assert_allclose(body.derivative(tuple(x), tuple(tau), tuple(v_c)),
                                   numpy_derivative(body, x, tau, v_c, hydro),
                                   rtol=1e-10, atol=1e-12)


def _neutral_payload(profile: Profile, where: str) -> str:
    """A weight at ``where`` that makes the vehicle exactly neutrally buoyant."""
    kg = (profile.buoyancy_N - profile.weight_N) / profile.gravity_m_s2
    assert kg > 0
    return f"{kg!r}@{where}"


@pytest.mark.parametrize(("name", "payload", "seconds"), [
    ("sabertooth", "10@AftSB", 240.0),           # sinks: equal added masses, no Munk moment
    ("bluerov", "neutral@W-aft-stbd", 60.0),     # no linear roll damping: rolls on slowly
])
def test_passive_equilibrium_solves_g_eta_zero(request: pytest.FixtureRequest, name: str,
                                              payload: str, seconds: float) -> None:
    profile: Profile = request.getfixturevalue(name)
    if payload.startswith("neutral@"):
        payload = _neutral_payload(profile, payload.split("@")[1])
    item = parse_payload(payload, profile)[0]
    W, r_g = payload_truth(profile, item.mass_kg, np.array(item.position_m))

    def moments(angles: np.ndarray) -> np.ndarray:
        g = restoring_forces(angles[0], angles[1], W, profile.buoyancy_N, r_g, profile.r_b_m)
        return g[3:5]

    expected = fsolve(moments, [0.0, 0.0], xtol=1e-12)
    v = SimVehicle(profile, replace(QUIET, payload=payload, armed=False))
    v.run_for(seconds)
    angles = []
    for _ in range(1200):      # mean over 60 s: a residual oscillation averages out
        v.run_for(0.05)
        angles.append(v.truth.eta[3:5])
    assert np.degrees(np.abs(expected)).max() > 1.0      # really unbalanced
    np.testing.assert_allclose(np.mean(angles, axis=0), expected, atol=math.radians(0.01))


def _hold(profile: Profile, config: SimConfig, tilt_deg: float, settle_s: float,
          collect_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hold roll = pitch = tilt; return, at 10 Hz over the collect window,
    τ from the PWM outputs (through the profile's curves), g(η) at the true attitude, and
    the true body velocity."""
    v = SimVehicle(profile, config)
    a = math.radians(tilt_deg)
    v.hold_attitude(a, a, 0.0)
    v.run_for(settle_s)
    taus, gs, nus = [], [], []
    for _ in range(round(collect_s * 10)):
        v.run_for(0.1)
        taus.append(tau_from_pwm(profile, v.pwm_us, v.voltage_V))
        gs.append(v.truth.g_eta)
        nus.append(v.truth.nu)
    return np.array(taus), np.array(gs), np.array(nus)


def _tolerance(tau: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Per-row tolerance: 4 standard errors of the mean (samples 1 s apart taken as
    independent), plus 1 % of the row's size and the thrust of one PWM step."""
    n_eff = len(tau) / 10
    return 4 * tau.std(axis=0) / math.sqrt(n_eff) + 0.01 * np.abs(g.mean(axis=0)) + 0.02


CASES = [("sabertooth", "10@AftSB"), ("bluerov", "0.4@W-aft-ctr")]


@pytest.mark.parametrize(("name", "payload"), CASES)
@pytest.mark.parametrize("station", [False, True])
def test_hold_tau_equals_g_eta(request: pytest.FixtureRequest, name: str, payload: str,
                               station: bool) -> None:
    """With a position fix every row of τ = g(η) holds. In depth hold without station
    keeping the rows held are the world vertical and the moments: the vehicle drifts (at a
    tilt, and wherever the thrusters' asymmetric curves leave a net horizontal force) and
    the force rows balance g(η) together with the drag of that drift (docs/method.md §3)."""
    profile: Profile = request.getfixturevalue(name)
    config = SimConfig(payload=payload, seed=2, station=station)
    lin, quad = np.array(profile.linear_damping), np.array(profile.quadratic_damping)
    for tilt in (0.0, 20.0):
        tau, g, nu = _hold(profile, config, tilt, settle_s=40.0, collect_s=60.0)
        tol = _tolerance(tau, g)
        err = np.abs(tau.mean(axis=0) - g.mean(axis=0))
        rows = slice(0, 6) if station else slice(2 if tilt == 0 else 3, 6)
        assert np.all(err[rows] < tol[rows]), (tilt, err, tol)
        drag = ((lin + quad * np.abs(nu)) * nu)[:, :3]
        balance = np.abs((tau[:, :3] + drag - g[:, :3]).mean(axis=0))
        assert np.all(balance < tol[:3] + 0.05 * np.abs(drag).max()), (tilt, balance)
        if not station and tilt > 0:
            assert np.linalg.norm(nu[:, :3].mean(axis=0)) > 0.01   # holds depth, not station


def test_free_decay_follows_damping_law(bluerov: Profile) -> None:
    """Neutral, balanced vehicle (weight at CG0): surge decays as
    (m + X_u̇)·u̇ = X_u·u + X_u|u|·|u|·u, sway and yaw (purely quadratic) likewise."""
    payload = _neutral_payload(bluerov, "0,0,0")
    v = SimVehicle(bluerov, replace(QUIET, payload=payload, armed=False))
    m = v.mass.mass_kg
    t = np.arange(1, 301) * 0.02
    for axis, x0 in ((0, 0.5), (1, 0.4), (5, 1.0)):
        nu0 = [0.0] * 6
        nu0[axis] = x0
        v.x = initial_state(5.0, nu=nu0)
        observed = []
        for _ in t:
            v.run_for(0.02)
            observed.append(v.x[7 + axis])
        inertia = (m if axis < 3 else bluerov.inertia_kg_m2[axis - 3]) + bluerov.added_mass[axis]
        a, b = -bluerov.linear_damping[axis], -bluerov.quadratic_damping[axis]
        if a > 0:
            e = np.exp(-a * t / inertia)
            expected = a * x0 * e / (a + b * x0 * (1 - e))
        else:
            expected = x0 / (1 + b * x0 * t / inertia)
        np.testing.assert_allclose(observed, expected, rtol=1e-6)


@pytest.mark.parametrize("damping", [False, True])
def test_no_energy_gain(bluerov: Profile, damping: bool) -> None:
    """Unpowered, unbalanced and tumbling: total energy is conserved without damping and
    never rises with it."""
    v = SimVehicle(bluerov, replace(QUIET, payload="0.4@W-front-stbd", armed=False,
                                    damping=damping))
    v.x = initial_state(5.0, 0.6, -0.4, 0.2, (0.3, -0.2, 0.1, 1.5, -1.0, 2.0))
    energy = [v.body.energy(v.x)]
    for _ in range(600):
        v.run_for(0.05)
        energy.append(v.body.energy(v.x))
    e = np.array(energy)
    scale = abs(e[0]) + 0.5 * float(np.asarray(v.x[7:]) @ v.body.M @ np.asarray(v.x[7:])) + 1
    if damping:
        assert np.all(np.diff(e) <= 1e-9 * scale)
        assert e[-1] < e[0] - 0.5                          # and it does dissipate
    else:
        assert e.max() - e[0] <= 1e-9 * scale                 # RK4 may only lose energy
        assert np.abs(e - e[0]).max() < 1e-5 * scale


def test_same_seed_same_run_other_seed_other_noise(bluerov: Profile) -> None:
    runs = []
    for seed in (4, 4, 5):
        v = SimVehicle(bluerov, SimConfig(payload="0.4@W-aft-ctr", seed=seed))
        v.run_for(2.0)
        runs.append((v.x, v.pwm_us))
    assert runs[0] == runs[1]
    assert runs[0][0] != runs[2][0]
