"""What one stage's grey-box fit takes and gives (:func:`trimd.identify.fit.fit_stage`): its
settings (:class:`FitOptions`), each parameter's estimate (:class:`ParameterEstimate`)
and the stage's result (:class:`StageFit`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from trimd.core.types import FloatArray
from trimd.identify.excitation import MIN_EXCITATION, DofExcitation
from trimd.identify.model import Statics

__all__ = ["NEEDS_DVL", "NOT_DETERMINED", "FitOptions", "ParameterEstimate", "StageFit"]


#: Note of a parameter of surge or sway fitted from logs without body velocity.
NEEDS_DVL = "needs a DVL: profile's value kept (fitted only as the unmeasured motion)"
#: Note of a parameter the data did not determine (:attr:`ParameterEstimate.determined`).
NOT_DETERMINED = "not determined by the data"


@dataclass(frozen=True)
class FitOptions:
    """Settings of :func:`~trimd.identify.fit.fit_stage`.

    Attributes
    ----------
    segment_s : simulation horizon of each segment [s].
    step_s : longest integration step of the fit [s]: the simulation steps over whole
        samples, as many as fit in it (at least one), and is compared at those samples.
    weights : per output name (u, v, w, p, q, r, phi, theta) the weight of its error;
        outputs not named get 1/std of the measured output.
    lag_s : thruster lag [s] when it is not fitted.
    fit_lag : estimate the thruster lag (starting from the best of
        :data:`~trimd.identify.start.LAG_GRID`) and
        the lead of the thruster record (starting from half a sample interval).
    fixed : parameters held at the given value (named as in the report).
    max_rel_std : relative standard deviation above which a parameter counts as not
        determined by the data.
    max_iter : Jacobian evaluations (iterations) per least-squares run.
    min_excitation : share of the thrusters' authority the spread of τ_i must reach for
        DOF i to be fitted (:data:`~trimd.identify.excitation.MIN_EXCITATION`,
        :func:`~trimd.identify.excitation.excitation_of`).
    """

    segment_s: float = 4.0
    step_s: float = 0.04
    weights: Mapping[str, float] = field(default_factory=dict)
    lag_s: float = 0.05
    fit_lag: bool = True
    fixed: Mapping[str, float] = field(default_factory=dict)
    max_rel_std: float = 0.3
    max_iter: int = 30
    min_excitation: float = MIN_EXCITATION


@dataclass(frozen=True)
class ParameterEstimate:
    """One named parameter: estimate, standard deviation (NaN when fixed), the profile's
    value (prior), whether it was estimated and why not."""

    name: str
    value: float
    std: float
    prior: float
    free: bool
    note: str = ""

    @property
    def determined(self) -> bool:
        """Estimated, and determined by the data (a fragment may use it)."""
        return self.free and self.note not in (NOT_DETERMINED, NEEDS_DVL)


@dataclass(frozen=True, eq=False)
class StageFit:
    """Result of :func:`~trimd.identify.fit.fit_stage`.

    Attributes
    ----------
    stage : stage name.
    parameters : every hydrodynamic parameter and the lag (fixed ones with their value),
        then the bias parameters.
    correlation : correlation matrix of the free parameters, in ``free_names`` order.
    free_names : names of the estimated parameters.
    rms_residual : RMS of the weighted residuals at the optimum.
    n_samples : samples used (all experiments).
    nfev : simulations of the least-squares runs (Jacobians count one each).
    warnings : parameters the data did not determine, and other caveats.
    share : per estimated hydrodynamic parameter, the share of its DOF's force or moment
        per unit change of the parameter at the experiments' typical motion (|δ|·share is
        the share a change δ makes: the judge of a negligible coefficient).
    excitation : per DOF of the stage, how much the data excited it; the parameters of a
        DOF that was not excited are not fitted (profile's values, noted).
    statics : the mass and restoring terms the fit held fixed.
    """

    stage: str
    parameters: tuple[ParameterEstimate, ...]
    correlation: FloatArray
    free_names: tuple[str, ...]
    rms_residual: float
    n_samples: int
    nfev: int
    warnings: tuple[str, ...]
    share: Mapping[str, float] = field(default_factory=dict)
    excitation: tuple[DofExcitation, ...] = ()
    statics: Statics | None = None

    @property
    def not_excited(self) -> tuple[DofExcitation, ...]:
        """The DOFs of the stage the data did not excite (their parameters not fitted)."""
        return tuple(d for d in self.excitation if not d.excited)

    def values(self) -> dict[str, float]:
        return {p.name: p.value for p in self.parameters}

    def __getitem__(self, name: str) -> ParameterEstimate:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)
