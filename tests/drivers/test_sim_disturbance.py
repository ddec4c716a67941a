"""Slow disturbances of the simulated vehicle (``disturb=real`` and its options).

Each disturbance is a first-order Gauss–Markov process: over a long simulated run its
standard deviation must be the stated amplitude and its autocorrelation at a lag of the
stated correlation time must be e⁻¹ ≈ 0.37. The tolerances (±30 % on σ, 0.22–0.52 on the
autocorrelation) are several standard errors wide at these run lengths and exclude a
factor-2 error of either: 2σ or σ/2 is off by 100 % / 50 %, and τ/2 or 2τ gives an
autocorrelation of 0.14 or 0.61.
"""

from __future__ import annotations

import asyncio
import math
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from trimd.core.errors import LinkError
from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Thrusters
from trimd.drivers.sim.config import DISTURB_REAL, SimConfig, parse_sim_options, with_presets
from trimd.drivers.sim.disturbance import Disturbances, GaussMarkov
from trimd.drivers.sim.link import SimLink
from trimd.drivers.sim.vehicle import SimVehicle

SIGMA_TOL = 0.3
RHO_AT_TAU = (0.22, 0.52)


def sigma_and_rho(x: np.ndarray, lag: int) -> tuple[float, float]:
    """Standard deviation of the columns of ``x`` (about zero: the processes have zero
    mean) pooled, and their autocorrelation at ``lag`` samples pooled."""
    x = np.asarray(x, float).reshape(len(x), -1)
    var = float(np.mean(x ** 2))
    return math.sqrt(var), float(np.mean(x[lag:] * x[:-lag]) / var)


def assert_gauss_markov(x: np.ndarray, dt_s: float, sigma: float, tau_s: float) -> None:
    s, rho = sigma_and_rho(x, round(tau_s / dt_s))
    assert abs(s / sigma - 1) < SIGMA_TOL, (s, sigma)
    assert RHO_AT_TAU[0] < rho < RHO_AT_TAU[1], (rho, tau_s)


def test_gauss_markov_process_has_its_sigma_and_correlation_time() -> None:
    gm = GaussMarkov(0.7, 5.0, 0.01, 3, np.random.default_rng(1))
    x = np.array([gm.step() for _ in range(300_000)])    # 3000 s, 600 correlation times
    s, rho = sigma_and_rho(x, 500)
    assert abs(s / 0.7 - 1) < 0.05
    assert abs(rho - math.exp(-1)) < 0.05
    assert abs(sigma_and_rho(x, 100)[1] - math.exp(-0.2)) < 0.03   # exponential decay
    assert abs(float(np.corrcoef(x[:, 0], x[:, 1])[0, 1])) < 0.05   # independent components
    with pytest.raises(ValueError, match="positive"):
        GaussMarkov(1.0, 0.0, 0.01, 1, np.random.default_rng(0))


def test_off_by_default_and_presets_set_then_options_override() -> None:
    assert not Disturbances(SimConfig(), 8).active
    real = parse_sim_options("disturb=real")
    assert real == with_presets(disturb="real")
    assert all(getattr(real, k) == v for k, v in DISTURB_REAL.items())
    assert 1 / 3 <= real.thrusters_hz / real.attitude_hz <= 1 / 2
    assert real.ahrs_wander_deg >= 0.1 and real.ahrs_wander_tau_s >= 5
    # a preset applies before the other keys, wherever it stands
    for text in ("disturb=real,ahrs_wander_deg=0.2", "ahrs_wander_deg=0.2,disturb=real"):
        c = parse_sim_options(text)
        assert (c.ahrs_wander_deg, c.depth_wander_m) == (0.2, DISTURB_REAL["depth_wander_m"])
    assert parse_sim_options("disturb=none", base=real) == SimConfig()
    for bad in ("disturb=rough", "disturbance=real"):
        with pytest.raises(LinkError, match="disturb"):
            parse_sim_options(bad)


def test_one_disturbance_does_not_change_another() -> None:
    def ahrs(config: SimConfig) -> list[tuple[float, ...]]:
        d = Disturbances(config, 8)
        out = []
        for _ in range(2000):
            d.step()
            out.append(d.ahrs_rad)
        return out

    one = replace(SimConfig(seed=4), ahrs_wander_deg=0.1)
    assert ahrs(one) == ahrs(replace(one, thruster_dither_us=3.0, current_wander_m_s=0.1))
    assert ahrs(one) != ahrs(replace(one, seed=5))


@pytest.mark.slow
def test_sensor_and_current_wander_on_the_vehicle(bluerov: Profile) -> None:
    """At rest and disarmed (noise off): the AHRS, depth and gyro errors and the current are
    the configured processes, seen through the vehicle's own readings."""
    tau = 5.0
    c = parse_sim_options(f"seed=3,armed=0,mode=MANUAL,noise=0,gyro_bias_rad_s=0,"
                          f"ahrs_wander_deg=0.2,ahrs_wander_tau_s={tau},"
                          f"depth_wander_m=0.05,depth_wander_tau_s={tau},"
                          f"gyro_wander_deg_s=0.05,gyro_wander_tau_s={tau},"
                          f"current_wander_m_s=0.04,current_wander_tau_s={tau}")
    v = SimVehicle(bluerov, c)
    dt = 0.1
    attitude, depth, gyro, current = [], [], [], []
    for _ in range(round(1500 / dt)):      # 300 correlation times
        v.run_for(dt - c.dt_s)
        t = v.truth
        v.step()
        r = v.reading                      # read from the state of t
        attitude.append((r.phi - t.eta[3], r.theta - t.eta[4]))
        depth.append(r.depth_m - t.eta[2])
        gyro.append((r.p - t.nu[3], r.q - t.nu[4], r.r - t.nu[5]))
        current.append(v.sensors.current(v.t_s)[:2])
    assert_gauss_markov(np.degrees(attitude), dt, 0.2, tau)
    assert_gauss_markov(np.array(depth), dt, 0.05, tau)
    assert_gauss_markov(np.degrees(gyro), dt, 0.05, tau)
    assert_gauss_markov(np.array(current), dt, 0.04, tau)


@pytest.mark.slow
def test_held_attitude_wanders_by_the_stated_amount(bluerov: Profile) -> None:
    """In ALT_HOLD the vehicle (true and reported attitude alike) wanders about the held
    attitude by ``attitude_wander_deg``."""
    tau = 5.0
    v = SimVehicle(bluerov, SimConfig(seed=2, noise=0.0, attitude_wander_deg=0.3,
                                      attitude_wander_tau_s=tau, payload="0.4@W-aft-ctr"))
    v.hold_attitude(math.radians(10), math.radians(-10), 0.0)
    v.run_for(60.0)
    dt, true, reported = 0.1, [], []
    for _ in range(round(1500 / dt)):
        v.run_for(dt)
        true.append(v.truth.eta[3:5] - np.radians([10, -10]))
        reported.append((v.reading.phi - math.radians(10), v.reading.theta + math.radians(10)))
    assert_gauss_markov(np.degrees(true), dt, 0.3, tau)
    assert_gauss_markov(np.degrees(reported), dt, 0.3, tau)


def test_thruster_dither_in_the_reported_pwm(bluerov: Profile) -> None:
    """Open loop (outputs fixed): the reported PWM is the output plus the dither process,
    rounded to whole µs."""
    tau, sigma = 0.3, 4.0
    v = SimVehicle(bluerov, SimConfig(seed=1, noise=0.0, thruster_dither_us=sigma,
                                      thruster_dither_tau_s=tau))
    v.open_loop((0.0, 0.0, 0.5, 0.0, 0.0, 0.0))
    v.run_for(1.0)
    dt, pwm = 0.01, []
    for _ in range(round(300 / dt)):       # 1000 correlation times
        v.step()
        pwm.append(v.sample("thrusters").pwm_us)     # type: ignore[attr-defined]
    pwm_a = np.array(pwm)
    still = SimVehicle(bluerov, SimConfig(seed=1, noise=0.0))
    still.open_loop((0.0, 0.0, 0.5, 0.0, 0.0, 0.0))
    still.run_for(1.0)
    assert_gauss_markov(pwm_a - np.array(still.pwm_us), dt, math.hypot(sigma, 12 ** -0.5), tau)


def test_disturb_real_thrusters_at_a_fraction_of_the_attitude_rate(bluerov: Profile) -> None:
    async def counts() -> Counter[type]:
        link = SimLink(SimVehicle(bluerov, with_presets(SimConfig(seed=1), disturb="real")))
        out: Counter[type] = Counter()
        async for s in link.samples():
            if s.t_s >= 60.0:
                break
            out[type(s)] += 1
        return out

    n = asyncio.run(counts())
    assert n[Attitude] == 600 and n[Thrusters] == 240       # 10 Hz and 4 Hz
    assert 1 / 3 <= n[Thrusters] / n[Attitude] <= 1 / 2
