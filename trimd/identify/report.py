"""Outputs of an identification: a profile fragment (YAML), a JSON summary and a text table.

The fragment uses the profile schema (``docs/profile.md``): ``added_mass`` and ``damping``
with the identified values, the profile's value where nothing was identified. Roll, pitch
and yaw give only the sums I + added inertia; the fragment keeps the profile's rigid
inertia and writes the rest as added inertia (or lowers the inertia when the sum is below
it, saying so in a comment).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from trimd.core.jsonsafe import json_number
from trimd.core.profile import Profile
from trimd.identify.fit import StageFit
from trimd.identify.model import HYDRO_NAMES
from trimd.identify.validation import Validation

__all__ = ["best_values", "excitation_dict", "format_fit", "profile_fragment",
           "statics_dict", "summary_dict"]

_DOFS = ("surge", "sway", "heave", "roll", "pitch", "yaw")
_ADDED = ("surge_kg", "sway_kg", "heave_kg", "roll_kg_m2", "pitch_kg_m2", "yaw_kg_m2")


def best_values(fits: Sequence[StageFit]) -> dict[str, float]:
    """Per hydrodynamic parameter, the estimate with the smallest standard deviation among
    the stages whose data determined it."""
    best: dict[str, tuple[float, float]] = {}
    for fit in fits:
        for p in fit.parameters:
            if p.determined and p.name in HYDRO_NAMES and (p.name not in best
                                                      or p.std < best[p.name][1]):
                best[p.name] = (p.value, p.std)
    return {k: v for k, (v, _) in best.items()}


def profile_fragment(values: Mapping[str, float], profile: Profile,
                     comments: Sequence[str] = ()) -> str:
    """YAML text of ``added_mass``, ``inertia_kg_m2`` and ``damping`` (module docstring);
    ``comments`` are added as comment lines under the heading (e.g. what was not
    identified)."""
    lines = [f"# identified by trimd identify for profile {profile.name}"]
    lines += [f"# {c}" for c in comments]
    inertia = list(profile.inertia_kg_m2)
    added = list(profile.added_mass)
    notes = []
    for i in range(6):
        v = values.get(HYDRO_NAMES[i])
        if v is None:
            continue
        if i < 3:
            added[i] = v
        elif v >= inertia[i - 3]:
            added[i] = v - inertia[i - 3]
        else:
            notes.append(f"# {HYDRO_NAMES[i]} = {v:.6g} is below the profile's inertia "
                         f"{inertia[i - 3]:.6g}: inertia lowered, added inertia 0")
            inertia[i - 3], added[i] = v, 0.0
    lines += notes
    lines.append("inertia_kg_m2: [" + ", ".join(f"{v:.6g}" for v in inertia) + "]")
    lines.append("added_mass:")
    lines += [f"  {k}: {v:.6g}" for k, v in zip(_ADDED, added, strict=True)]
    lines.append("damping:")
    for label, offset, own in (("linear", 6, profile.linear_damping),
                               ("quadratic", 12, profile.quadratic_damping)):
        vals = [values.get(HYDRO_NAMES[offset + i], own[i]) for i in range(6)]
        lines.append(f"  {label}: {{" + ", ".join(
            f"{d}: {min(v, 0.0):.6g}" for d, v in zip(_DOFS, vals, strict=True)) + "}")
    return "\n".join(lines) + "\n"


def excitation_dict(fit: StageFit) -> dict[str, Any]:
    """Per DOF of the stage: τ spread and the thrusters' authority [N or N·m], their ratio,
    the threshold, and whether it counts as excited."""
    return {d.name: {"tau_spread": d.spread, "authority": d.authority, "ratio": d.ratio,
                     "threshold": d.threshold, "excited": d.excited}
            for d in fit.excitation}


def statics_dict(fit: StageFit) -> dict[str, Any] | None:
    """The mass [kg] and restoring terms [N, N·m] the fit held fixed, and their source."""
    s = fit.statics
    if s is None:
        return None
    return {"source": s.source, "mass_kg": s.mass_kg, "net_force_N": float(s.q_rest[0]),
            "net_moment_Nm": [float(v) for v in s.q_rest[1:]]}


def summary_dict(fits: Sequence[StageFit], validations: Mapping[str, Sequence[Validation]]
                 ) -> dict[str, Any]:
    """JSON-ready summary: per stage every parameter (value, std, prior, free, note),
    the excitation of each DOF and the DOFs not excited, the fixed mass and restoring
    terms, warnings, correlations of the free parameters, and the validation NRMSE per
    output."""
    out: dict[str, Any] = {"stages": {}}
    for fit in fits:
        out["stages"][fit.stage] = {
            "parameters": {p.name: {"value": p.value, "std": json_number(p.std), "prior": p.prior,
                                    "free": p.free, "note": p.note}
                           for p in fit.parameters},
            "free": list(fit.free_names),
            "excitation": excitation_dict(fit),
            "not_excited": [d.name for d in fit.not_excited],
            "statics": statics_dict(fit),
            "correlation": [[json_number(float(c)) for c in row] for row in fit.correlation],
            "rms_residual": fit.rms_residual, "samples": fit.n_samples,
            "simulations": fit.nfev, "warnings": list(fit.warnings),
            "validation": [{"label": v.label,
                            "nrmse_pct": {o: None if x is None else json_number(x)
                                          for o, x in v.judged().items()},
                            "not_excited": [o for o, x in v.judged().items() if x is None]}
                           for v in validations.get(fit.stage, ())],
        }
    return out


def _context(fit: StageFit) -> list[str]:
    """The excitation per DOF and the fixed mass and restoring terms, one line each."""
    rows = []
    if fit.excitation:
        rows.append(f"  excitation (τ spread / thrusters' authority, at least "
                    f"{100 * fit.excitation[0].threshold:g} %): " + ", ".join(
                        f"{d.name} {100 * d.ratio:.3g} %" + ("" if d.excited
                                                             else " NOT EXCITED")
                        for d in fit.excitation))
    if fit.statics is not None:
        q = fit.statics.q_rest
        rows.append(f"  mass and restoring terms from {fit.statics.source}: m "
                    f"{fit.statics.mass_kg:.4g} kg, W − B {q[0]:+.4g} N, W·r_g − B·r_b ("
                    + ", ".join(f"{v + 0.0:+.4g}" for v in q[1:]) + ") N·m")
    return rows


def format_fit(fit: StageFit, validations: Sequence[Validation] = ()) -> str:
    """Table of estimate ± std beside the profile's value, the excitation per DOF, the
    fixed mass and restoring terms, warnings and validation fits."""
    rows = [f"stage {fit.stage}: {fit.n_samples} samples, {fit.nfev} simulations, "
            f"RMS weighted residual {fit.rms_residual:.4g}", *_context(fit),
            f"  {'parameter':<12} {'estimate':>12} {'± std':>10} {'profile':>12}"]
    for p in fit.parameters:
        if p.free or p.note:
            std = f"{p.std:10.3g}" if math.isfinite(p.std) else f"{'fixed':>10}"
            rows.append(f"  {p.name:<12} {p.value:12.5g} {std} {p.prior:12.5g} {p.note}")
    rows += [f"  warning: {w}" for w in fit.warnings]
    for v in validations:
        rows.append(f"  validation {v.label}: NRMSE % {v.describe()}")
    return "\n".join(rows)
