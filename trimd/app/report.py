"""Readable text of what trimd found: the estimate, the proposal, a session's result and the
commands it sent, as the headless daemon, the TUI's report and the CLI print them.

Lengths are shown in millimetres, angles in degrees; ± is one standard deviation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from trimd.app.apply import Applied
from trimd.app.results import AnyResult
from trimd.ballast.correct import Correction
from trimd.ballast.propose import Proposal
from trimd.ballast.verify import VERIFIED, Verification
from trimd.core.estimate import HoldSamples, StaticEstimate
from trimd.core.floating import Z95, FloatResult
from trimd.core.profile import InstalledPiece
from trimd.core.samples import Command, Health, HoldAttitude, Release

__all__ = ["NewCommands", "NewWarnings", "describe_command", "format_applied",
           "format_correction", "format_estimate", "format_float", "format_proposal",
           "format_result", "format_verification", "undecided_advice"]


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
        *(f"note: {n}" for n in est.notes),
    ]
    return "\n".join(lines)


def format_proposal(p: Proposal) -> str:
    """A readable table: the loaded slots, added mass, net buoyancy, passive attitude."""
    status = "feasible" if p.feasible else "NOT FEASIBLE: best achievable"
    lines = [f"ballast by {p.method}: {status}",
             f"{'slot':<14}{'x m':>8}{'y m':>8}{'z m':>8}{'weight kg':>11}{'float kgf':>11}"
             f"{'net down N':>12}  pieces"]
    for s in p.slots:
        if s.mass_kg or s.buoyancy_N:
            pieces = ", ".join([*(f"+{n} × {name}" if s.removed else f"{n} × {name}"
                                  for name, n in s.pieces),
                                *(f"−{n} × {name}" for name, n in s.removed)])
            lines.append(f"{s.name:<14}{s.position_m[0]:8.3f}{s.position_m[1]:8.3f}"
                         f"{s.position_m[2]:8.3f}{s.weight_kg:11.3f}{s.float_kg:11.3f}"
                         f"{s.net_down_N:12.2f}  {pieces}")
    t = p.trim
    if p.installed or any(s.removed for s in p.slots):
        lines += [f"installed before  {_pieces_text(p.installed)}",
                  *(f"  {c.text}" for c in p.changes),
                  f"installed after   {_pieces_text(p.installed_after)}",
                  f"pieces handled    {p.pieces_handled} (a move counts once)"]
    lines += [
        f"added mass        {p.added_mass_kg:.3f} kg",
        f"net buoyancy      {t.net_buoyancy_N:+.2f} ± {t.net_buoyancy_std_N:.2f} N "
        f"({t.net_buoyancy_pct:+.2f} % of weight)",
        *((f"passive roll      {t.roll_deg:+.3f} ± {t.roll_std_deg:.3f}°",
           f"passive pitch     {t.pitch_deg:+.3f} ± {t.pitch_std_deg:.3f}°") if t.stable
          else ("passive trim      undefined: no static stability",)),
        f"binding           {'; '.join(p.binding) or 'none'}",
        p.message,
    ]
    known = Z95 * max(t.roll_std_deg, t.pitch_std_deg)
    if t.stable and p.level_tol_deg > 0 and known > p.level_tol_deg:
        lines.append(f"undecided: the passive roll and pitch are known to ±{known:.2f}° at 95 %,"
                     f" wider than the level tolerance ±{p.level_tol_deg:g}°: after "
                     "ballasting, float (trimd float --correct) or verify (trimd run "
                     "--verify) to measure what is left")
    return "\n".join(lines)


def _pieces_text(pieces: Sequence[InstalledPiece]) -> str:
    return "; ".join(f"{x.count} × {x.piece} in {x.slot}" for x in pieces) or "none"


def format_applied(a: Applied) -> str:
    """What ``trimd ballast apply`` (or the TUI's apply) recorded, the changes from before
    and, with an estimate, the physics check of the configuration."""
    lines = [f"recorded for vehicle {a.vehicle} in {a.db} ({a.source}):",
             f"  {_pieces_text(a.installed)}",
             f"changed from {a.before_from}: " + ("; ".join(a.changes) or "nothing")]
    t = a.trim
    if t is not None:
        lines.append(f"physics check: passive roll {t.roll_deg:+.3f} ± {t.roll_std_deg:.3f}°, "
                     f"pitch {t.pitch_deg:+.3f} ± {t.pitch_std_deg:.3f}°, net buoyancy "
                     f"{t.net_buoyancy_N:+.2f} N ({t.net_buoyancy_pct:+.2f} % of weight)"
                     if t.stable else
                     "physics check: no static stability, passive trim undefined")
    return "\n".join(lines)


def format_verification(v: Verification) -> str:
    """A readable table of a verify hold: measured, predicted and their difference."""
    predicted = np.r_[-v.predicted.net_buoyancy_N, v.predicted.net_moment_Nm[:2]]
    measured_std = np.sqrt(np.diag(v.measured.q_cov))[:3]
    lines = [f"verify hold ({v.measured.samples} samples, {v.measured.t_start_s:.1f} – "
             f"{v.measured.t_end_s:.1f} s)",
             f"{'':<32}{'measured':>18}{'predicted':>12}{'difference':>20}"]
    for name, m, m_std, p, d, d_std in zip(VERIFIED, v.measured.q[:3], measured_std, predicted,
                                            v.difference, v.difference_std, strict=True):
        lines.append(f"{name:<32}{m:+10.3f} ± {m_std:5.3f}{p:+12.3f}{d:+12.3f} ± {d_std:5.3f}")
    lines.append(v.message)
    return "\n".join(lines)


def format_level_hold(hold: HoldSamples) -> str:
    """A calibration's level hold (:mod:`trimd.app.calibrate`): its steady samples and
    their mean τ on the rows a level hold measures (Z, K, M)."""
    z, k, m = np.mean(hold.tau[:, 2:5], axis=0)
    return (f"level hold ({len(hold.t_s)} steady samples, {hold.t_s[0]:.1f} – "
            f"{hold.t_s[-1]:.1f} s): mean τ Z {z:+.3f} N, K {k:+.3f} N·m, M {m:+.3f} N·m; "
            "a calibration is all its holds: trimd calibrate --replay HOLD1 HOLD2 …")


def format_float(r: FloatResult) -> str:
    """A float check's result (:mod:`trimd.core.floating`): the attitude ± (95 %), where
    the ± comes from, the depth's drift and the verdict."""
    parts = ", ".join(f"{axis} statistics {Z95 * s:.2f}°, transient {Z95 * t:.2f}°, "
                      f"drift {Z95 * d:.2f}°"
                      for axis, s, t, d in zip(("roll", "pitch"), r.stat_std_deg,
                                               r.transient_deg, r.drift_deg, strict=True))
    return (f"float check: {r.message}\n  ± (95 %) from {parts}, the attitude reference's "
            f"error in both; settled after {r.settle_s:.1f} s; depth changed "
            f"{r.depth_change_m:+.2f} m ({r.depth_rate_m_s:+.3f} m/s while collecting, "
            "positive down)")


def undecided_advice(v: Verification) -> str | None:
    """What the operator can do when a verify hold found the vehicle level but cannot tell
    (:attr:`Verification.undecided`); None when it can."""
    if not v.undecided:
        return None
    return (f"level, but undecided: the passive roll and pitch are known to "
            f"±{v.known_95_deg:.2f}° at "
            f"95 %, wider than the level tolerance ±{v.level_tol_deg:g}°: float (trimd float "
            "--correct) measures it without the thrust map; trimd calibrate --band teaches "
            "trimd this vehicle's dead-band edges and narrows later holds")


def format_correction(c: Correction | None, source: str = "the verify hold") -> str:
    """The correction from ``source`` (a verify hold's, a float check's:
    :mod:`trimd.ballast.correct`) as a proposal's table, or that none is needed."""
    if c is None:
        return "no correction needed: level and as predicted"
    return (f"correction from {source} (the vehicle as measured, from the ballast "
            "installed now):\n" + format_proposal(c.proposal))


def format_result(result: AnyResult) -> str | None:
    """The estimate and proposal, or a verify hold's verification (a calibration's level
    hold, a float check's result), as the headless daemon prints them (None: none)."""
    if isinstance(result.verification, Verification):
        return format_verification(result.verification)
    if isinstance(result.verification, HoldSamples):
        return format_level_hold(result.verification)
    if isinstance(result.verification, FloatResult):
        return format_float(result.verification)
    if result.estimate is None:
        return None
    text = format_estimate(result.estimate)
    proposal = result.proposal
    return text if proposal is None else text + "\n\n" + format_proposal(proposal)


def describe_command(command: Command) -> str:
    """A short description of a command for the log."""
    if isinstance(command, HoldAttitude):
        return (f"hold roll {math.degrees(command.phi):.1f}°, pitch "
                f"{math.degrees(command.theta):.1f}°, yaw {math.degrees(command.psi):.1f}°")
    if isinstance(command, Release):
        return "release control"
    return repr(command)


#: An attitude command that moves roll and pitch by no more than this [deg] from the one
#: before continues it (a ramp step: ``procedure.tilt_rate_deg_s`` over one attitude
#: sample, 0.3° at 5°/s and 16 Hz, 1.25° at the slowest attitude stream trimd accepts).
RAMP_STEP_DEG = 1.5


class NewCommands:
    """The commands each presenter shows: every command, except an attitude command that
    moved roll and pitch by at most :data:`RAMP_STEP_DEG` from the one before: a hold's
    set-point sent again with only its heading moved along
    (``trimd.core.procedure.HEADING_LEASH_DEG``), or a step of the ramp to a hold
    (``trimd.core.ramp``; the hold's own line says where it goes). Dozens per trim, in the
    session log, not news to the operator."""

    def __init__(self) -> None:
        self._held: tuple[float, float] | None = None

    def __call__(self, command: Command) -> str | None:
        """The command's log line, or None when it is not news."""
        held = (command.phi, command.theta) if isinstance(command, HoldAttitude) else None
        last, self._held = self._held, held
        step = math.radians(RAMP_STEP_DEG)
        if held is not None and last is not None and all(
                abs(h - g) <= step for h, g in zip(held, last, strict=True)):
            return None
        return describe_command(command)


class NewWarnings:
    """The link's warnings each presenter shows once: those of a Health sample not seen
    before (a link repeats its warnings in every Health sample)."""

    def __init__(self) -> None:
        self._seen: set[str] = set()

    def __call__(self, health: Health) -> list[str]:
        new = [w for w in health.warnings() if w not in self._seen]
        self._seen.update(new)
        return new
