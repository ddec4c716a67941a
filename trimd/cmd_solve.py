"""``trimd solve HOLDS.csv --profile P [--json]``: the static estimate from recorded holds."""

from __future__ import annotations

import argparse
import json
from typing import Any

from trimd.ballast import METHODS, format_proposal, proposal_to_dict, propose_ballast
from trimd.estimate import StaticEstimate, estimate_static
from trimd.estimate_io import estimate_to_dict
from trimd.holdfile import read_hold_csv
from trimd.profile import load_profile

__all__ = ["format_estimate", "register", "run"]


def register(sub: Any) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "solve", help="estimate the centre of gravity and extra mass from a hold CSV",
        description="Estimate weight, extra mass and centre of gravity from steady holds "
        "(see trimd/holdfile.py for the CSV columns).")
    p.add_argument("holds", help="CSV of samples: time_s, roll_deg, pitch_deg and τ or pwm_N")
    p.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--ballast", nargs="?", const="milp", choices=METHODS, metavar="METHOD",
                   help=f"also propose ballast ({', '.join(METHODS)}; default milp)")
    p.set_defaults(func=run)


def format_estimate(est: StaticEstimate) -> str:
    """A readable table of the estimate, ± 1σ, lengths in millimetres."""
    lines = [f"{'hold':<10}{'roll °':>8}{'pitch °':>9}{'samples':>9}   steady window [s]"]
    for h in est.holds:
        lines.append(f"{h.label:<10}{h.roll_deg:8.2f}{h.pitch_deg:9.2f}{h.samples:9d}   "
                     f"{h.t_start_s:.1f} – {h.t_end_s:.1f}")
    mm, mm_std = est.r_g_m * 1e3, est.r_g_std_m * 1e3
    M, M_std = est.net_moment_Nm, est.net_moment_std_Nm
    lines += [
        "",
        f"weight W           {est.weight_N:12.2f} ± {est.weight_std_N:.2f} N"
        f"   (buoyancy B = {est.buoyancy_N:.2f} N from the profile)",
        f"extra mass m_ext   {est.m_ext_kg:12.3f} ± {est.m_ext_std_kg:.3f} kg",
        *(f"centre of gravity {a} {v:10.2f} ± {s:.2f} mm"
          for a, v, s in zip(("x_g", "y_g", "z_g"), mm, mm_std, strict=True)),
        f"net vertical force W − B  {est.q[0]:.2f} ± {est.q_cov[0, 0] ** 0.5:.2f} N",
        *(f"net moment W·{a}_g − B·{a}_b  {v:.3f} ± {s:.3f} N·m"
          for a, v, s in zip("xyz", M, M_std, strict=True)),
        f"rows used: {', '.join(est.dofs_used)}",
    ]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    est = estimate_static(read_hold_csv(args.holds, profile), profile)
    proposal = propose_ballast(est, profile, method=args.ballast) if args.ballast else None
    if args.json:
        out = estimate_to_dict(est)
        if proposal is not None:
            out["ballast"] = proposal_to_dict(proposal)
        print(json.dumps(out))
    else:
        print(format_estimate(est))
        if proposal is not None:
            print("\n" + format_proposal(proposal))
    return 0
