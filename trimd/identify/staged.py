"""The staged identification of the thesis (docs/method.md §5): uvr → uwq → uvwpqr.

Each stage is fitted on its own experiments (:func:`trimd.identify.fit.fit_stage`) in
that order; every hydrodynamic parameter an earlier stage determined is held at that
stage's estimate in the later ones (surge and sway from uvr, heave and pitch from uwq), so
the coupled uvwpqr stage fits what is left: roll, and whatever the earlier stages did not
determine. Stages without experiments are skipped.

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

from trimd.core.errors import EstimationError
from trimd.core.profile import Profile
from trimd.identify.data import Experiment
from trimd.identify.fit import FitOptions, StageFit, fit_stage
from trimd.identify.model import HYDRO_NAMES, STAGES, Statics

__all__ = ["carried", "fit_stages"]


def carried(fits: Sequence[StageFit]) -> dict[str, float]:
    """The hydrodynamic parameters the ``fits`` determined, each from the first stage that
    did (the one a later stage was given)."""
    out: dict[str, float] = {}
    for fit in fits:
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
    for stage in STAGES:
        if not experiments.get(stage):
            continue
        given = {n: v for n, v in carried(fits).items() if n in STAGES[stage].free_names
                 and n not in opts.fixed}
        fit = fit_stage(experiments[stage], profile, stage,
                        dataclasses.replace(opts, fixed={**opts.fixed, **given}),
                        statics=statics)
        fits.append(_noted(fit, given))
    return fits


def _noted(fit: StageFit, given: Mapping[str, float]) -> StageFit:
    """``fit`` with the parameters carried into it noted as such."""
    if not given:
        return fit
    params = tuple(dataclasses.replace(p, note="carried from an earlier stage")
                   if p.name in given and not p.note else p for p in fit.parameters)
    return dataclasses.replace(fit, parameters=params)
