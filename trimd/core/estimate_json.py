"""The JSON shape of a static estimate (``trimd solve --json``) and its reader.

The shape is an interface: ``trimd ballast --estimate EST.json`` and the daemon's
``--json`` output use it. Units are in the key names; vectors are body FRD.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from trimd.core.errors import DataError
from trimd.core.estimate import HoldSummary, StaticEstimate

__all__ = ["covariance_problem", "estimate_from_dict", "estimate_to_dict"]


def estimate_to_dict(est: StaticEstimate) -> dict[str, Any]:
    """A JSON-ready dict: weight, m_ext, centre of gravity, net quantities, covariances."""
    return {
        "weight_N": est.weight_N,
        "weight_std_N": est.weight_std_N,
        "buoyancy_N": est.buoyancy_N,
        "r_b_m": est.r_b_m.tolist(),
        "gravity_m_s2": est.gravity_m_s2,
        "m_ext_kg": est.m_ext_kg,
        "m_ext_std_kg": est.m_ext_std_kg,
        "cg_m": est.r_g_m.tolist(),
        "cg_std_m": est.r_g_std_m.tolist(),
        "net_force_N": float(est.q[0]),
        "net_moment_Nm": est.net_moment_Nm.tolist(),
        "net_moment_std_Nm": est.net_moment_std_Nm.tolist(),
        "cov_W_cg": est.cov.tolist(),
        "cov_net": est.q_cov.tolist(),
        "dofs_used": list(est.dofs_used),
        "residual_rms": est.residual_rms.tolist(),
        "holds": [{"label": h.label, "roll_deg": h.roll_deg, "pitch_deg": h.pitch_deg,
                   "samples": h.samples, "steady_window_s": [h.t_start_s, h.t_end_s]}
                  for h in est.holds],
        "notes": list(est.notes),
    }


def _array(d: dict[str, Any], key: str, shape: tuple[int, ...], source: str) -> np.ndarray:
    if key not in d:
        raise DataError(f"{source}: missing '{key}' (expected the output of trimd solve --json)")
    try:
        a = np.asarray(d[key], dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{source}: '{key}' is not numeric") from None
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise DataError(f"{source}: '{key}' must be {shape} finite numbers, got {d[key]!r}")
    return a


def covariance_problem(cov: np.ndarray) -> str | None:
    """Why ``cov`` is not a covariance matrix (square, finite, symmetric, positive
    semi-definite, each to rounding), or None when it is one."""
    if cov.ndim != 2 or cov.shape[0] != cov.shape[1]:
        return f"is not a square matrix (shape {cov.shape})"
    if not np.all(np.isfinite(cov)):
        return "has a non-finite entry"
    scale = float(np.max(np.abs(cov), initial=0.0))
    if np.max(np.abs(cov - cov.T), initial=0.0) > 1e-9 * scale:
        return "is not symmetric"
    lowest = float(np.linalg.eigvalsh((cov + cov.T) / 2).min(initial=0.0))
    if lowest < -1e-9 * scale:
        return f"is not positive semi-definite (eigenvalue {lowest:.3g})"
    return None


def _covariance(d: dict[str, Any], key: str, size: int, source: str) -> np.ndarray:
    """The covariance matrix at ``key``; DataError naming the key if it is not one."""
    cov = _array(d, key, (size, size), source)
    problem = covariance_problem(cov)
    if problem is not None:
        raise DataError(f"{source}: '{key}' {problem}: not a covariance matrix")
    return cov


def estimate_from_dict(d: object, source: str = "<estimate>") -> StaticEstimate:
    """Rebuild a :class:`StaticEstimate` from :func:`estimate_to_dict` output."""
    if not isinstance(d, dict):
        raise DataError(f"{source}: expected a JSON object from trimd solve --json")
    scalars = {k: float(_array(d, k, (), source)) for k in
               ("weight_N", "buoyancy_N", "gravity_m_s2", "m_ext_kg")}
    if scalars["weight_N"] <= 0 or not math.isfinite(scalars["weight_N"]):
        raise DataError(f"{source}: weight_N must be positive")
    try:
        holds = tuple(HoldSummary(str(h.get("label", "")), float(h["roll_deg"]),
                                  float(h["pitch_deg"]), int(h["samples"]),
                                  float(h["steady_window_s"][0]),
                                  float(h["steady_window_s"][1]))
                      for h in d.get("holds", []))
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise DataError(f"{source}: malformed 'holds' entry ({exc!r}); expected label, "
                        "roll_deg, pitch_deg, samples, steady_window_s") from None
    net_force = (float(_array(d, "net_force_N", (), source)) if "net_force_N" in d
                 else scalars["weight_N"] - scalars["buoyancy_N"])
    q = np.concatenate([[net_force], _array(d, "net_moment_Nm", (3,), source)])
    return StaticEstimate(
        q=q, q_cov=_covariance(d, "cov_net", 4, source), weight_N=scalars["weight_N"],
        buoyancy_N=scalars["buoyancy_N"], r_b_m=_array(d, "r_b_m", (3,), source),
        r_g_m=_array(d, "cg_m", (3,), source), cov=_covariance(d, "cov_W_cg", 4, source),
        m_ext_kg=scalars["m_ext_kg"], gravity_m_s2=scalars["gravity_m_s2"], holds=holds,
        dofs_used=tuple(str(x) for x in d.get("dofs_used", [])),
        residual_rms=np.asarray(d.get("residual_rms", [math.nan] * 6), dtype=float),
        notes=tuple(str(n) for n in d.get("notes", [])))
