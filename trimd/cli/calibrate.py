"""``trimd calibrate --link URL --profile P --mass KG@SLOT [--mass KG@SLOT …]``: a
deliberate calibration of the thrust map (:mod:`trimd.app.calibrate`; docs/method.md §7):
a level hold, the operator hangs a known weight at a known slot, a second level hold; with
more ``--mass``, the operator swaps the weight for the next before each further hold
(``--mass A+B`` hangs two at once). ``--band`` on a trimmed vehicle: trimd chooses the loads
from the holds, those that make its vertical thrusters hunt at the upper, then the lower
edges of their dead bands, aimed again while a hold misses a thruster's edge
(:mod:`trimd.app.calibrate_band`, docs/method.md §7). Each
experiment is checked and stored in the vehicle's trim history as soon as it is made, and
every later session of the vehicle uses it. Each hold is recorded (``-calibrate-1``,
``-calibrate-2``, … in the log's name); ``trimd calibrate --replay HOLD1 HOLD2 …``
reproduces the experiments and their outcomes from the recordings.
"""

from __future__ import annotations

import argparse
import asyncio
import re
import sys
from collections.abc import Callable
from pathlib import Path

from trimd.app.calibrate import calibrate_with_weights, checked_hold_s, light_weight_advice
from trimd.app.calibrate_band import BAND_TRIES
from trimd.app.calibration_loads import CalibrationRun, KnownWeight, Load
from trimd.app.connect import open_link
from trimd.app.files import default_record_path
from trimd.app.history.calibration import calibrated_profile
from trimd.app.jsonlines import print_result
from trimd.app.replay import replay_calibration
from trimd.cli.argtypes import Subcommands
from trimd.cli.history_args import add_history_args, db_path, vehicle_of
from trimd.core.errors import ProfileError, UsageError
from trimd.core.learnt import band_edge_to_dict, band_edges, gain_to_dict, gains
from trimd.core.profile import Profile
from trimd.core.profile_yaml import load_profile, read_profile_text
from trimd.logs.recorder import TlogRecorder

__all__ = ["register", "run"]

_MASS = re.compile(r"^(?P<kg>[-+]?\d+(\.\d*)?|[-+]?\.\d+)@(?P<slot>.+)$")


def register(sub: Subcommands) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "calibrate", help="calibrate the thrust map with a known weight",
        description="A level hold, then you hang a known weight at a ballast slot, then a "
        "second level hold: the thrusters' answer to the known weight calibrates their "
        "thrust map, stored in the vehicle's trim history and used by every later trim, "
        "verify hold and watch of the vehicle (docs/method.md §7).")
    p.add_argument("--link", help="sim[:opts] | mavlink:<conn> | serial:<dev>[,<baud>] "
                   "(required unless --replay)")
    p.add_argument("--profile", help="vehicle profile (YAML path or name; required unless "
                   "--replay: the recordings carry theirs)")
    p.add_argument("--mass", metavar="KG@SLOT", action="append",
                   help="the weight's net downward force in water [kgf] (negative: a "
                   "float's lift) and the ballast slot it hangs at, e.g. 0.5@W-front-stbd "
                   "(required unless --replay). Give it again for a series: before each "
                   "further level hold you swap the weight for the next (a weight and a "
                   "float at each corner teach the most, docs/method.md §7); "
                   "KG@SLOT+KG@SLOT hangs several at once")
    p.add_argument("--band", action="store_true",
                   help="instead of --mass, on a trimmed vehicle: after the first level "
                   "hold trimd says what to hang (and where) to make the vehicle just heavy "
                   "enough for its vertical thrusters to hunt at the upper edges of their "
                   "dead bands, which the next hold shows (a load aimed again while a hold "
                   f"misses a thruster's edge, up to {BAND_TRIES} holds), then what to swap "
                   "it for to make it just buoyant enough for the lower edges, likewise: "
                   "the edges a later trim of the vehicle works beyond (docs/method.md §7)")
    p.add_argument("--uncertainty-pct", type=float, default=1.0,
                   help="1σ of the weight in water [%%] (default 1)")
    p.add_argument("--hold-s", type=float, metavar="S",
                   help="collect each level hold for S seconds (default: the profile's "
                   "collect_max_s): longer holds check each experiment more sharply, e.g. "
                   "catch an inventory entry a few %% off (docs/method.md §7); recorded, so "
                   "--replay collects as long")
    p.add_argument("--yes", action="store_true", help="command the vehicle without asking, "
                   "and take each weight as hung once the hold before it ends (headless)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--no-history", action="store_true",
                   help="check the experiment against the profile alone; store nothing")
    p.add_argument("--record", metavar="PATH", help="where to record the holds: PATH with "
                   "-calibrate-1, -calibrate-2, … in its name (default: timestamped logs in "
                   "the data directory's sessions/)")
    p.add_argument("--no-record", action="store_true", help="do not record the holds")
    p.add_argument("--replay", nargs="+", metavar="HOLD",
                   help="reproduce a calibration from the recordings of its holds, in order "
                   "(two or more): the experiments checked against the thrust map the live "
                   "session had, stored nowhere")
    add_history_args(p)
    p.set_defaults(func=run)


def _sides(done: CalibrationRun) -> tuple[bool | None, ...]:
    """Each experiment's band side (True: the upper edges'); None throughout where the
    calibration does not say (a calibration with weights, a replay of older recordings)."""
    return done.sides if len(done.sides) == len(done.outcomes) else (None,) * len(
        done.outcomes)


def _load(text: str, uncertainty_pct: float) -> Load:
    """``--mass KG@SLOT[+KG@SLOT…]``: the weights hung together for one hold."""
    found = [_MASS.match(item.strip()) for item in text.split("+")]
    if not all(found):
        raise UsageError(f"--mass {text!r}: expected KG@SLOT (or KG@SLOT+KG@SLOT to hang "
                         "several at once), e.g. 0.5@W-front-stbd", "trimd calibrate")
    return tuple(KnownWeight(float(m["kg"]), m["slot"].strip(), uncertainty_pct)
                 for m in found if m is not None)


def _ask(text: str) -> bool:
    print(f"trimd calibrate: {text} [y/N] ", end="", file=sys.stderr, flush=True)
    return sys.stdin.readline().strip().lower() in ("y", "yes")


def _recorder(args: argparse.Namespace, profile: Profile
              ) -> Callable[[dict[str, object]], TlogRecorder] | None:
    """Each hold's recorder: ``--record`` (or a timestamped log) with the hold's name."""
    if args.no_record:
        return None
    base = Path(args.record) if args.record else default_record_path(profile)
    yaml_text = read_profile_text(args.profile)[0]

    def recorder(hold: dict[str, object]) -> TlogRecorder:
        k = int(str(hold["hold"])) + 1
        path = base.with_name(f"{base.stem}-calibrate-{k}{base.suffix or '.tlog'}")
        return TlogRecorder(path, profile, yaml_text, calibration_hold=hold)

    return recorder


def _live(args: argparse.Namespace) -> CalibrationRun | None:
    """The calibration on the vehicle; None when the operator did not confirm it."""
    if args.band and args.mass:
        raise UsageError("--band chooses the load itself: give --band or --mass, not both",
                         "trimd calibrate")
    missing = [f"--{k}" for k in ("link", "profile") if not getattr(args, k)] + (
        [] if args.mass or args.band else ["--mass (or --band)"])
    if missing:
        raise UsageError(f"{', '.join(missing)} required (or --replay HOLD1 HOLD2 …)",
                         "trimd calibrate")
    profile = load_profile(args.profile)
    weights = [_load(m, args.uncertainty_pct) for m in args.mass or []]
    for w in (w for load in weights for w in load):
        profile.slot(w.slot)  # a wrong slot fails before anything is commanded
    advice = None if args.band else light_weight_advice(
        profile, [w for load in weights for w in load])
    if advice:
        print(f"trimd calibrate: note: {advice}", file=sys.stderr)
    if not args.yes and not sys.stdin.isatty():
        raise ProfileError("headless without a terminal cannot ask for confirmation: "
                           "pass --yes to let trimd command the vehicle")
    holds = f"up to {2 * BAND_TRIES + 1}" if args.band else f"{len(weights) + 1}"
    if not args.yes and not _ask(f"{holds} level holds: let trimd command the vehicle?"):
        return None
    vehicle = vehicle_of(args, profile.name)
    db = None if args.no_history else Path(db_path(args))
    profile = calibrated_profile(db, vehicle, profile)

    def hung(text: str, _load: Load) -> bool:
        if args.yes:
            print(f"trimd calibrate: {text} (--yes: taken as done)", file=sys.stderr)
            return True
        return _ask(text)

    run: CalibrationRun = asyncio.run(calibrate_with_weights(
        lambda: open_link(args.link, profile), profile, weights, hung, db=db, vehicle=vehicle,
        record=_recorder(args, profile), hold_s=args.hold_s,
        band_pct=args.uncertainty_pct if args.band else None))
    return run


def run(args: argparse.Namespace) -> int:
    if args.replay and args.hold_s is not None:
        raise UsageError("--hold-s is the live calibration's: a replay collects each hold "
                         "as long as its recording says", "trimd calibrate")
    checked_hold_s(args.hold_s)  # before anything is asked or commanded
    if args.replay:
        done: CalibrationRun | None = asyncio.run(replay_calibration(args.replay, args.profile))
    else:
        done = _live(args)
    if done is None:
        return 1
    vehicle = vehicle_of(args, done.profile.name)
    determined = [g for g in gains(done.posterior, done.profile) if g.determined]
    edges = [b for b in band_edges(done.posterior, done.profile) if b.determined]
    accepted = all(o.accepted for o in done.outcomes)
    lines = [o.message for o in done.outcomes] + ([done.stopped] if done.stopped else []) + [
        f"  {g.thruster} {g.direction}: {g.mean_pct:+.1f} ± {g.std_pct:.1f} % "
        f"(prior ± {g.prior_std_pct:.1f} %)" for g in determined] + [
        f"  {b.thruster} band {b.edge} edge: {b.mean_us:+.1f} ± {b.std_us:.1f} µs "
        f"(prior ± {b.prior_std_us:.1f} µs)" for b in edges]
    print_result(args.json, {
        "type": "calibration", "vehicle": vehicle, "accepted": accepted,
        "experiments_run": [{"label": o.label, "accepted": o.accepted, "message": o.message,
                             "chi2": o.chi2, "sigma": o.sigma,
                             **({"band_edges_side": "upper" if up else "lower"}
                                if up is not None else {})}
                            for o, up in zip(done.outcomes, _sides(done), strict=True)],
        "stopped": done.stopped, "experiments": done.posterior.experiments,
        "gains": [gain_to_dict(g) for g in determined],
        "band_edges": [band_edge_to_dict(b) for b in edges]}, "\n".join(lines))
    return 0 if accepted and not done.stopped else 1
