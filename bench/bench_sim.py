"""Simulated vehicle: real-time factor at 100 Hz (BlueROV2 Heavy), beside bare numpy RK4.

The real-time factor is simulated seconds per wall second of the whole vehicle step
(sensors, controller, mixer, thrusters, RK4 dynamics) holding the tilted trim attitude.
The reference is a plain numpy RK4 loop of the same equations of motion
(:func:`numpy_derivative`, which ``tests/drivers/test_sim_physics.py`` also checks against the
simulator's own scalar implementation), with nothing else in the loop.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from bench.size import size
from bench.timing import best_time
from trimd.core.profile_yaml import load_profile
from trimd.drivers.sim.config import SimConfig, with_presets
from trimd.drivers.sim.dynamics import RigidBody, initial_state
from trimd.drivers.sim.vehicle import SimVehicle

FloatArray = NDArray[np.float64]

SIM_S = size(20.0, 1.0)


def numpy_derivative(body: RigidBody, x: FloatArray, tau: FloatArray, v_c: FloatArray,
                     hydro: tuple[FloatArray, FloatArray, FloatArray]) -> FloatArray:
    """ẋ of :class:`RigidBody` written with numpy arrays (Fossen eq. 10.1; same state);
    ``hydro`` = (added mass, linear damping, quadratic damping), profile order and signs."""
    q0, q1, q2, q3 = x[3:7]
    R = np.array([
        [1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
        [2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)],
        [2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)]])
    nu = x[7:13]
    v, w = nu[:3], nu[3:]
    nu_r = np.concatenate([v - R.T @ v_c, w])
    t = body.truth
    added, lin, quad = hydro
    M_A = np.diag(added)
    M_RB = body.M - M_A
    P = M_RB @ nu
    Pa = M_A @ nu_r
    C_RB = np.concatenate([np.cross(w, P[:3]), np.cross(w, P[3:]) + np.cross(v, P[:3])])
    C_A = np.concatenate([np.cross(w, Pa[:3]), np.cross(w, Pa[3:]) + np.cross(nu_r[:3], Pa[:3])])
    k = R[2]
    g = -np.concatenate([(t.W - t.B) * k, np.cross(t.W * t.r_g - t.B * t.r_b, k)])
    damp = (lin + quad * np.abs(nu_r)) * nu_r
    nu_dot = np.linalg.solve(body.M, tau + damp - C_RB - C_A - g)
    q_dot = 0.5 * np.array([-q1 * w[0] - q2 * w[1] - q3 * w[2], q0 * w[0] + q2 * w[2] - q3 * w[1],
                            q0 * w[1] - q1 * w[2] + q3 * w[0], q0 * w[2] + q1 * w[1] - q2 * w[0]])
    return np.concatenate([R @ v, q_dot, nu_dot])


def _numpy_rk4_loop(body: RigidBody, hydro: tuple[FloatArray, FloatArray, FloatArray],
                    steps: int, dt: float) -> FloatArray:
    """``steps`` RK4 steps of ``dt`` [s] of :func:`numpy_derivative` from a tilted, moving
    start (τ and current zero, quaternion renormalised); the final state."""
    x = np.array(initial_state(5.0, 0.3, 0.3, 0.0, (0.1, 0, 0, 0, 0, 0.1)))
    tau, v_c = np.zeros(6), np.zeros(3)
    for _ in range(steps):
        k1 = numpy_derivative(body, x, tau, v_c, hydro)
        k2 = numpy_derivative(body, x + 0.5 * dt * k1, tau, v_c, hydro)
        k3 = numpy_derivative(body, x + 0.5 * dt * k2, tau, v_c, hydro)
        k4 = numpy_derivative(body, x + dt * k3, tau, v_c, hydro)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[3:7] /= np.linalg.norm(x[3:7])
    return x


def main() -> None:
    profile = load_profile("bluerov2-heavy")
    config = SimConfig(payload="0.4@W-aft-ctr", dt_s=0.01)

    disturbed = with_presets(config, disturb="real", truth="perturbed")

    def run_vehicle(c: SimConfig = config) -> None:
        v = SimVehicle(profile, c)
        v.hold_attitude(math.radians(20), math.radians(20), 0.0)
        v.run_for(SIM_S)

    vehicle = SimVehicle(profile, config)
    hydro = (np.array(profile.added_mass), np.array(profile.linear_damping),
             np.array(profile.quadratic_damping))
    steps = round(SIM_S / config.dt_s)
    t_sim = best_time(run_vehicle, repeat=5)   # ~0.1 s each: best of 5 rides out a shared CPU
    t_disturbed = best_time(lambda: run_vehicle(disturbed), repeat=5)
    t_ref = best_time(lambda: _numpy_rk4_loop(vehicle.body, hydro, steps, config.dt_s),
                      repeat=3)
    body_only = best_time(lambda: _scalar_rk4_loop(vehicle.body, steps, config.dt_s), repeat=5)
    print(f"simulated vehicle ({profile.name}, 100 Hz, tilted hold, {SIM_S:.0f} s): "
          f"real-time factor {SIM_S / t_sim:.0f}× (requirement ≥ 100×)")
    print(f"  its RK4 dynamics alone: {SIM_S / body_only:.0f}×; bare numpy RK4 loop of the "
          f"same model: {SIM_S / t_ref:.0f}×; whole vehicle vs numpy dynamics: "
          f"{t_ref / t_sim:.1f}× faster")
    print(f"  with disturb=real,truth=perturbed: real-time factor {SIM_S / t_disturbed:.0f}×")


def _scalar_rk4_loop(body: RigidBody, steps: int, dt: float) -> None:
    """The same steps with the simulator's own scalar :meth:`RigidBody.rk4` (nothing else)."""
    x = initial_state(5.0, 0.3, 0.3, 0.0, (0.1, 0, 0, 0, 0, 0.1))
    tau, v_c = (0.0,) * 6, (0.0, 0.0, 0.0)
    for _ in range(steps):
        x = body.rk4(x, tau, v_c, dt)


if __name__ == "__main__":
    main()
