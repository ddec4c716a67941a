"""Unseen vehicles for judging an identification: a profile whose hydrodynamics differ from
a prior's by random factors, the damping force a parameter set gives at a speed, and the
rates an experiment reached (a damping force is judged within them: beyond, it is an
extrapolation no experiment of that vehicle checks).

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping

import numpy as np

from trimd.core.profile import Profile
from trimd.core.samples import Attitude, Sample, Velocity
from trimd.identify.model import HYDRO_NAMES

__all__ = ["damping_force", "perturbed", "rates_reached"]


def perturbed(profile: Profile, rng: np.random.Generator, spread: float = 0.5,
              name: str | None = None, buoyancy_spread: float = 0.0) -> Profile:
    """``profile`` with every inertia sum (rigid inertia and added inertia scaled
    together), added mass and linear and quadratic damping coefficient multiplied by its
    own factor drawn uniformly from [1 − spread, 1 + spread], and its buoyancy by one from
    [1 − buoyancy_spread, 1 + buoyancy_spread] (drawn last: the hydrodynamic factors of a
    seed do not depend on it); mass, geometry, thrusters and the centre of buoyancy
    unchanged."""
    def factors(n: int) -> np.ndarray:
        return rng.uniform(1.0 - spread, 1.0 + spread, n)

    rot = factors(3)
    i = np.asarray(profile.inertia_kg_m2, float) * rot
    a = np.asarray(profile.added_mass, float) * np.concatenate([factors(3), rot])
    dl = np.asarray(profile.linear_damping, float) * factors(6)
    dq = np.asarray(profile.quadratic_damping, float) * factors(6)
    buoyancy = profile.buoyancy_N * (float(rng.uniform(1 - buoyancy_spread, 1 + buoyancy_spread))
                                     if buoyancy_spread else 1.0)
    return dataclasses.replace(
        profile, name=name or f"{profile.name}-perturbed", buoyancy_N=buoyancy,
        inertia_kg_m2=(float(i[0]), float(i[1]), float(i[2])),
        added_mass=_vec6(a), linear_damping=_vec6(dl), quadratic_damping=_vec6(dq))


def _vec6(a: np.ndarray) -> tuple[float, float, float, float, float, float]:
    return (float(a[0]), float(a[1]), float(a[2]), float(a[3]), float(a[4]), float(a[5]))


def damping_force(values: Mapping[str, float], dof: int, speed: float) -> float:
    """Damping force or moment [N, N·m] of DOF ``dof`` (0..5) at ``speed`` [m/s, rad/s]
    from the linear and quadratic coefficients in ``values`` (Fossen's negative
    derivatives: the force opposes the motion, so it is negative for a positive speed)."""
    return (values[HYDRO_NAMES[6 + dof]] * speed
            + values[HYDRO_NAMES[12 + dof]] * abs(speed) * speed)


def rates_reached(samples: Iterable[Sample]) -> tuple[float, ...]:
    """Per DOF (u, v, w, p, q, r) the 99th percentile of the measured |ν_i| [m/s, rad/s]
    in ``samples`` (body velocity from the DVL's samples, inf without any)."""
    items = list(samples)
    uvw = np.array([[s.u, s.v, s.w] for s in items if isinstance(s, Velocity)])
    pqr = np.array([[s.p, s.q, s.r] for s in items if isinstance(s, Attitude)])
    linear = (np.percentile(np.abs(uvw), 99, axis=0) if len(uvw) else np.full(3, np.inf))
    return tuple(float(v) for v in (*linear, *np.percentile(np.abs(pqr), 99, axis=0)))
