"""The trim report the operator saves from the TUI: markdown for people, JSON for tools
(the estimate and proposal in the ``trimd solve --json`` / ``trimd ballast --json``
shapes), written side by side. Both state the ballast method of the proposal shown and
warn when that proposal is not feasible; after a verify hold, its verdict too (and a warning
when it is not as predicted)."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from trimd.app.report import (
    format_estimate,
    format_float,
    format_proposal,
    format_verification,
)
from trimd.ballast.proposal import Proposal, proposal_to_dict
from trimd.ballast.verify import Verification, verification_to_dict
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.floating import FloatResult, Verdict, float_to_dict

__all__ = ["Report", "save_report"]


@dataclass(frozen=True)
class Report:
    """What goes into a report; ``events`` are (session time [s], kind, text);
    ``verification`` the last check's outcome (a verify hold's or a float check's)."""

    profile: str
    link: str
    status: str
    log_path: str | None
    estimate: StaticEstimate | None
    proposal: Proposal | None
    truth: str | None
    events: Sequence[tuple[float, str, str]]
    verification: Verification | FloatResult | None = None


def _free_stem(directory: Path, stem: str) -> Path:
    """``directory/stem`` or, when a report of that name exists, ``stem-2``, ``stem-3``…"""
    name, n = stem, 1
    while (directory / f"{name}.md").exists() or (directory / f"{name}.json").exists():
        n += 1
        name = f"{stem}-{n}"
    return directory / name


def _warnings(r: Report) -> list[str]:
    """What the reader must not miss: an infeasible proposal, a verify hold not as
    predicted, a float check not level."""
    p, v = r.proposal, r.verification
    out = []
    if p is not None and not p.feasible:
        out.append(f"the {p.method} proposal is NOT FEASIBLE (best achievable): {p.message}")
    if isinstance(v, FloatResult) and v.verdict is not Verdict.LEVEL:
        out.append(f"the float check: {v.message}")
    elif isinstance(v, Verification) and not (v.as_predicted and v.level):
        out.append(f"the verify hold: {v.message}")
    return out


def _to_dict(r: Report) -> dict[str, Any]:
    return {
        "profile": r.profile, "link": r.link, "status": r.status, "log_path": r.log_path,
        "method": None if r.proposal is None else r.proposal.method,
        "warnings": _warnings(r),
        "estimate": None if r.estimate is None else estimate_to_dict(r.estimate),
        "proposal": None if r.proposal is None else proposal_to_dict(r.proposal),
        "truth": r.truth,
        "verification": (verification_to_dict(r.verification)
                         if isinstance(r.verification, Verification) else None),
        "float": (float_to_dict(r.verification) if isinstance(r.verification, FloatResult)
                  else None),
        "events": [{"t_s": None if math.isnan(t) else t, "kind": k, "text": text}
                   for t, k, text in r.events],
    }


def _to_markdown(r: Report) -> str:
    out = [f"# trimd report: {r.profile}", "", f"- link: `{r.link}`", f"- status: {r.status}",
           f"- session log: {f'`{r.log_path}`' if r.log_path else 'not recorded'}",
           f"- ballast method: {r.proposal.method if r.proposal else 'none (no proposal)'}",
           ""]
    out += [f"> **Warning**: {w}\n" for w in _warnings(r)]
    out += ["## Estimate", ""]
    out += (["```text", format_estimate(r.estimate), "```"] if r.estimate
            else ["No estimate: the procedure did not finish."])
    if r.proposal is not None:
        out += ["", f"## Ballast proposal ({r.proposal.method})", "", "```text",
                format_proposal(r.proposal), "```"]
    if isinstance(r.verification, Verification):
        out += ["", "## Verify hold", "", "```text", format_verification(r.verification),
                "```"]
    elif isinstance(r.verification, FloatResult):
        out += ["", "## Float check", "", "```text", format_float(r.verification), "```"]
    if r.truth:
        out += ["", "## Simulator truth", "", r.truth]
    out += ["", "## Events", "", "| t [s] | kind | event |", "|---:|---|---|"]
    out += [f"| {'—' if math.isnan(t) else f'{t:.2f}'} | {k} | {text.replace('|', '/')} |"
            for t, k, text in r.events]
    return "\n".join(out) + "\n"


def save_report(report: Report, directory: Path, stem: str) -> tuple[Path, Path]:
    """Write ``stem.md`` and ``stem.json`` in ``directory`` (never overwriting a
    report); return both paths."""
    directory.mkdir(parents=True, exist_ok=True)
    base = _free_stem(directory, stem)
    md, js = base.parent / f"{base.name}.md", base.parent / f"{base.name}.json"
    js.write_text(json.dumps(_to_dict(report), indent=2) + "\n", encoding="utf-8")
    md.write_text(_to_markdown(report), encoding="utf-8")
    return md, js
