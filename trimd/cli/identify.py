"""``trimd excite`` (an open-loop excitation experiment, recorded) and ``trimd identify``
(the staged grey-box fit of recorded experiments, :mod:`trimd.identify.staged`).

``trimd identify`` reads which stage each recording holds (a ``trimd excite`` recording
names it in the notice that starts the excitation; ``--stage`` for any other log, or to
override), fits the stages in the order uvr → uwq → uvwpqr carrying what earlier stages
determined, validates each held-out log on the outputs its experiment excited, and writes
one fragment, one summary and the plots.

``trimd excite`` keeps its envelope (:mod:`trimd.identify.envelope`): an experiment that
stops early at the edge of it is done (exit 0), says so on stderr, and its recording holds
every sample up to the stop; ``trimd identify`` fits it and names it (stderr, and
``stopped_early`` in its JSON).

Exit codes: 0 done, 1 failed or aborted, 2 usage, profile or data error (and logs that
excite none of a stage's degrees of freedom), 3 link error. ``trimd identify`` exits 1
when some degree of freedom of a fitted stage was excited by none of the logs: it still
prints (and with ``--out`` writes) what it identified, the rest keeps the profile's
values, but the result is incomplete and a script must not take the fragment for a full
result. ``trimd identify --json`` prints one ``identification`` line instead of the
tables: the summary (as ``summary.json``) and the fragment's YAML text.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Never

from trimd.app.files import read_statics
from trimd.app.jsonlines import print_result
from trimd.app.session import SessionResult
from trimd.cli.argtypes import Subcommands, bounded, integer
from trimd.core.errors import DataError
from trimd.core.events import Phase
from trimd.core.profile_yaml import load_profile, read_profile_text
from trimd.identify.envelope import STOP_EARLY
from trimd.identify.excitation import DofExcitation, not_excited_message
from trimd.identify.experiment import STREAM_HZ, Excite
from trimd.identify.fit import NEEDS_DVL, NOT_DETERMINED, FitOptions, StageFit
from trimd.identify.model import HYDRO_NAMES, STAGES
from trimd.identify.report import best_values, format_fit, profile_fragment, summary_dict
from trimd.identify.signals import KINDS, design_signal
from trimd.identify.staged import fit_stages
from trimd.identify.validation import Validation, validate

__all__ = ["register", "run_excite", "run_identify"]

#: Longest excitation experiment [s] (an hour; the signal is built in memory up front).
MAX_DURATION_S = 3600.0


def register(sub: Subcommands) -> None:
    e: argparse.ArgumentParser = sub.add_parser(
        "excite", help="run an open-loop excitation experiment for identification",
        description="Drive the axes of one identification stage open loop with a designed "
        "signal (docs/identification.md), recorded like any session. Commands the vehicle "
        "only after confirmation; releases it on any failure.")
    e.add_argument("--link", required=True, help="sim[:opts] | mavlink:<conn> | …")
    e.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    e.add_argument("--stage", required=True, choices=tuple(STAGES))
    e.add_argument("--signal", choices=KINDS, default="multistep")
    e.add_argument("--amplitude", type=bounded(0.0, 1.0), default=0.6, metavar="A",
                   help="largest input of the velocity axes, in (0, 1] (default 0.6; "
                   "raised on an axis the profile says would not reach 0.4 m/s or rad/s)")
    e.add_argument("--duration", type=bounded(0.0, MAX_DURATION_S), default=120.0,
                   metavar="S", help=f"seconds of excitation, in (0, {MAX_DURATION_S:g}] "
                   "(default 120)")
    e.add_argument("--seed", type=integer(0), default=0, help="random seed, ≥ 0")
    e.add_argument("--max-depth-excursion", type=bounded(0.0), default=5.0, metavar="M",
                   help="abort beyond this depth change from the start [m], > 0 (default 5)")
    e.add_argument("--yes", action="store_true", help="confirm up front")
    e.add_argument("--record", metavar="PATH", help="session log (default: a timestamped "
                   "file in $TRIMD_DATA_DIR or ~/.local/share/trimd/sessions, as trimd run)")
    e.add_argument("--no-record", action="store_true", help="do not write a session log")
    e.set_defaults(func=run_excite)
    i: argparse.ArgumentParser = sub.add_parser(
        "identify", help="fit the dynamic model to recorded excitation experiments",
        description="Staged grey-box output-error fit, uvr → uwq → uvwpqr "
        "(docs/identification.md).")
    i.add_argument("logs", nargs="+", metavar="LOG", help="recorded sessions (.tlog)")
    i.add_argument("--profile", required=True, help="vehicle profile (YAML path or name)")
    i.add_argument("--stage", choices=tuple(STAGES), default=None,
                   help="fit every log as this stage (default: the stage each trimd excite "
                   "recording names; required for other logs)")
    i.add_argument("--validate", nargs="+", default=[], metavar="LOG",
                   help="held-out sessions for the NRMSE fit")
    i.add_argument("--segment", type=bounded(0.0), default=FitOptions.segment_s, metavar="S",
                   help=f"simulation horizon of each segment [s], > 0 (default "
                   f"{FitOptions.segment_s:g})")
    i.add_argument("--estimate", metavar="EST.json", help="hold the weight and the restoring "
                   "terms (W − B, W·r_g − B·r_b) at a measured static estimate: the JSON of "
                   "trimd solve --json, the report JSON of trimd run, or trimd run --json "
                   "lines (default: the profile's nominal vehicle, r_g = 0)")
    i.add_argument("--out", metavar="DIR", help="write fragment.yaml, summary.json and PNG "
                   "plots (measured vs simulated per output, residuals) here")
    i.add_argument("--json", action="store_true", help="print one JSON object: the summary "
                   "(as summary.json) and the profile fragment")
    i.set_defaults(func=run_identify)


def run_excite(args: argparse.Namespace) -> int:
    from trimd.app.connect import open_link
    from trimd.app.experiment import run_experiment
    from trimd.app.files import default_record_path
    from trimd.logs.recorder import TlogRecorder

    profile = load_profile(args.profile)
    if not args.yes:
        raise DataError("trimd excite drives the vehicle open loop: pass --yes to confirm")
    sig = design_signal(profile, args.stage, kind=args.signal, amplitude=args.amplitude,
                        duration_s=args.duration, seed=args.seed,
                        depth_excursion_m=args.max_depth_excursion)
    excite = Excite(profile, sig, confirmed=True, depth_excursion_m=args.max_depth_excursion,
                    stage=args.stage)

    async def go() -> SessionResult[Never, Never]:
        link = await open_link(args.link, profile, stream_hz=STREAM_HZ)
        recorder = None
        if not args.no_record:
            path = Path(args.record) if args.record else default_record_path(profile)
            recorder = TlogRecorder(path, profile,
                                    read_profile_text(args.profile)[0])
        result, _ = await run_experiment(link, profile, excite, recorder=recorder,
                                         quiet=False, signals=True)
        return result

    result = asyncio.run(go())
    if result.phase is not Phase.DONE:
        print(f"trimd: {result.phase.value}: {result.reason}", file=sys.stderr)
    elif result.reason.startswith(STOP_EARLY):
        print(f"trimd: {result.reason}", file=sys.stderr)
    if result.log_path:
        print(f"session log: {result.log_path}", file=sys.stderr)
    return 0 if result.phase is Phase.DONE else (3 if result.cause == "link" else 1)


def _missing(fits: Sequence[StageFit]) -> list[tuple[StageFit, tuple[DofExcitation, ...]]]:
    """Per fit, its DOFs that no fitted stage excited."""
    excited = {d.dof for f in fits for d in f.excitation if d.excited}
    out = []
    for f in fits:
        missing = tuple(d for d in f.not_excited if d.dof not in excited)
        if missing:
            out.append((f, missing))
    return out


def run_identify(args: argparse.Namespace) -> int:
    from trimd.app.excite_logs import experiments_by_stage  # reads logs

    profile = load_profile(args.profile)
    statics = read_statics(args.estimate) if args.estimate else None
    experiments, early = experiments_by_stage(args.logs, profile, args.stage)
    fits = fit_stages(experiments, profile, FitOptions(segment_s=args.segment),
                      statics=statics)
    by_name = {f.stage: f for f in fits}
    best = best_values(fits)

    def values(stage: str) -> dict[str, float]:
        """The fit of ``stage`` if there is one, else the last stage's with the best
        estimate of every parameter."""
        if stage in by_name:
            return by_name[stage].values()
        return fits[-1].values() | best

    validations: dict[str, list[Validation]] = {}
    held_out_by_stage, early_held_out = experiments_by_stage(args.validate, profile,
                                                             args.stage)
    for stage, held_out in held_out_by_stage.items():
        for e in held_out:
            validations.setdefault(stage, []).extend(
                validate(values(stage), [e], profile, stage, statics=statics))
    missing = _missing(fits)
    comments = [f"{d.name}: not excited in the fitted logs, the profile's values kept"
                for _, ds in missing for d in ds]
    comments += [f"{p.name}: {NOT_DETERMINED}, the profile's value kept"
                 for f in fits for p in f.parameters
                 if p.note == NOT_DETERMINED and p.name not in best]
    blind = sorted({p.name for f in fits for p in f.parameters
                    if p.note == NEEDS_DVL and p.name not in best}, key=HYDRO_NAMES.index)
    if blind:
        comments.append(f"{', '.join(blind)}: need a DVL (no body velocity in these logs), "
                        "the profile's values kept")
    fragment = profile_fragment(best, profile, comments)
    print_result(args.json, {"type": "identification", **summary_dict(fits, validations),
                             "stopped_early": early | early_held_out, "fragment": fragment},
                 "\n\n".join(format_fit(f, validations.get(f.stage, ())) for f in fits)
                 + "\n\n" + fragment)
    if args.out:
        shown = [v for vs in validations.values() for v in vs] or [
            v for stage, es in experiments.items()   # without held-out logs: the fitted ones
            for e in es for v in validate(values(stage), [e], profile, stage,
                                          statics=statics)]
        _write(Path(args.out), fits, fragment, shown, validations)
    for path, text in early.items():
        print(f"trimd: {path}: {text}", file=sys.stderr)
    for fit, ds in missing:
        print(f"trimd: {not_excited_message(fit.stage, ds)}", file=sys.stderr)
    return 1 if missing else 0


def _write(out: Path, fits: Sequence[StageFit], fragment: str, shown: Sequence[Validation],
           validations: Mapping[str, Sequence[Validation]]) -> None:
    """fragment.yaml, summary.json and a PNG per series of ``shown`` in ``out``."""
    from trimd.app.plots import write_plots

    out.mkdir(parents=True, exist_ok=True)
    (out / "fragment.yaml").write_text(fragment, encoding="utf-8")
    (out / "summary.json").write_text(json.dumps(summary_dict(fits, validations), indent=2),
                                      encoding="utf-8")
    plots = write_plots(shown, out, "-".join(f.stage for f in fits))
    print(f"wrote {out / 'fragment.yaml'}, {out / 'summary.json'} and {len(plots)} "
          "plots (measured vs simulated, residuals)", file=sys.stderr)
