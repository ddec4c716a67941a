"""The staged identification of the thesis (docs/method.md §5): uvr → uwq → uvwpqr.

Each stage is fitted on its own experiments (:func:`trimd.identify.fit.fit_stage`) in
that order; every hydrodynamic parameter an earlier stage determined is held at that
stage's estimate in the later ones (surge and sway from uvr, heave and pitch from uwq), so
the coupled uvwpqr stage fits what is left: roll, and whatever the earlier stages did not
determine. Stages without experiments are skipped.

A stage that compares a single degree of freedom carries nothing: uvr without a DVL,
where only yaw is measured. The yaw time constant (the Sabertooth's 0.16 s) is close to
the thrusters' spin-up lag, and with nothing else to pin the lag the two trade off (the
yaw inertia sum up to 16.8 % off in docs/identification.md's reduced Monte Carlo, 0.99 %
since); uvwpqr, where heave, roll and pitch pin the lag, refits yaw, and of the two
estimates the one with the smaller standard deviation is used
(:func:`trimd.identify.report.best_values`).

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

from trimd.core.errors import EstimationError
from trimd.core.profile import Profile
from trimd.identify.data import Experiment
from trimd.identify.fit import FitOptions, StageFit, fit_stage
from trimd.identify.model import HYDRO_NAMES, STAGES, Statics, observed

__all__ = ["carried", "fit_stages"]


def carried(fits: Sequence[StageFit], single: Sequence[bool] = ()) -> dict[str, float]:
    """The hydrodynamic parameters the ``fits`` determined, each from the first stage that
    did (the one a later stage was given), skipping the fits whose ``single`` flag is
    set (they compared a single degree of freedom: module docstring)."""
    out: dict[str, float] = {}
    for k, fit in enumerate(fits):
        if k < len(single) and single[k]:
            continue
        for p in fit.parameters:
            if p.name in HYDRO_NAMES and p.determined and p.name not in out:
                out[p.name] = p.value
    return out


def fit_stages(experiments: Mapping[str, Sequence[Experiment]], profile: Profile,
               options: FitOptions | None = None, *, statics: Statics | None = None
               ) -> list[StageFit]:
    """Fit the stages that have experiments, in the order of
    :data:`trimd.identify.model.STAGES`, carrying what earlier stages determined
    (module docstring).

    Raises
    ------
    EstimationError
        For a stage name that is not uvr, uwq or uvwpqr, or without any experiment; and
        whatever :func:`trimd.identify.fit.fit_stage` raises.
    """
    unknown = set(experiments) - set(STAGES)
    if unknown:
        raise EstimationError(f"unknown stages {sorted(unknown)} "
                              f"(stages: {', '.join(STAGES)})")
    if not any(experiments.values()):
        raise EstimationError("no experiment to fit")
    opts = options or FitOptions()
    fits: list[StageFit] = []
    single: list[bool] = []
    for stage in STAGES:
        if not experiments.get(stage):
            continue
        given = {n: v for n, v in carried(fits, single).items()
                 if n in STAGES[stage].free_names and n not in opts.fixed}
        fit = fit_stage(experiments[stage], profile, stage,
                        dataclasses.replace(opts, fixed={**opts.fixed, **given}),
                        statics=statics)
        fits.append(_noted(fit, given))
        single.append(len(_compared_dofs(fit, all(e.dvl for e in experiments[stage]))) == 1)
    return fits


def _compared_dofs(fit: StageFit, dvl: bool) -> tuple[int, ...]:
    """The degrees of freedom whose outputs ``fit`` compared: those of its stage the data
    excited and the sensors observe (:func:`trimd.identify.model.observed`)."""
    excited = tuple(d.dof for d in fit.excitation if d.excited)
    return observed(STAGES[fit.stage], dvl).restricted(excited).dofs


def _noted(fit: StageFit, given: Mapping[str, float]) -> StageFit:
    """``fit`` with the parameters carried into it noted as such."""
    if not given:
        return fit
    params = tuple(dataclasses.replace(p, note="carried from an earlier stage")
                   if p.name in given and not p.note else p for p in fit.parameters)
    return dataclasses.replace(fit, parameters=params)
