"""How much the experiments of a stage excited each degree of freedom: the spread of the
commanded generalised force against what the thrusters can give on that axis.

Pure computation: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trimd.core.profile import Profile
from trimd.identify.data import Experiment
from trimd.identify.model import Stage
from trimd.identify.signals import axis_authority

__all__ = ["DOF_NAMES", "MIN_EXCITATION", "DofExcitation", "excitation_of",
           "not_excited_message"]

#: A DOF counts as excited when the spread of its generalised force τ_i in the data (the
#: standard deviation about each experiment's mean) is at least this share of what the
#: thrusters can give on that axis (:func:`trimd.identify.signals.axis_authority`). Measured on
#: the simulator (docs/identification.md): 3.4–34 % on the axes a stage excites, at most
#: 1.4 % on the others (the BlueROV2 Heavy's attitude hold).
MIN_EXCITATION = 0.02
#: Degrees of freedom and the symbols of their generalised forces, in order.
DOF_NAMES = ("surge", "sway", "heave", "roll", "pitch", "yaw")
_FORCE_NAMES = ("X", "Y", "Z", "K", "M", "N")


@dataclass(frozen=True)
class DofExcitation:
    """How much the experiments excited one degree of freedom.

    Attributes
    ----------
    dof : 0..5 (surge, sway, heave, roll, pitch, yaw).
    spread : standard deviation of τ_i about each experiment's mean [N or N·m].
    authority : what the thrusters can give on that axis [N or N·m]
        (:func:`trimd.identify.signals.axis_authority`).
    threshold : the share of ``authority`` the spread must reach (:data:`MIN_EXCITATION`).
    """

    dof: int
    spread: float
    authority: float
    threshold: float

    @property
    def ratio(self) -> float:
        """Spread over authority (0.01 = 1 %)."""
        return self.spread / self.authority if self.authority > 0 else 0.0

    @property
    def excited(self) -> bool:
        return self.ratio >= self.threshold

    @property
    def name(self) -> str:
        return DOF_NAMES[self.dof]

    def describe(self) -> str:
        """E.g. "τ_Z spread 0.73 %" (of the authority)."""
        return f"τ_{_FORCE_NAMES[self.dof]} spread {100 * self.ratio:.2g} %"


def excitation_of(experiments: Sequence[Experiment], profile: Profile, stage: Stage,
                  threshold: float = MIN_EXCITATION) -> tuple[DofExcitation, ...]:
    """Per DOF of ``stage``, the spread of τ_i in ``experiments`` (standard deviation about
    each experiment's own mean, pooled: a constant trim force is no excitation) against
    the thrusters' authority on that axis (:func:`trimd.identify.signals.axis_authority`)."""
    authority = axis_authority(profile)
    tau = np.concatenate([e.tau - e.tau.mean(axis=0) for e in experiments])
    spread = np.sqrt(np.mean(tau * tau, axis=0))
    return tuple(DofExcitation(i, float(spread[i]), float(authority[i]), threshold)
                 for i in stage.dofs)


def _join(words: Sequence[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def not_excited_message(stage: str, missing: Sequence[DofExcitation]) -> str:
    """What is wrong and what to do when DOFs of ``stage`` were not excited."""
    verb = "was" if len(missing) == 1 else "were"
    return (f"{_join([d.name for d in missing])} {verb} not excited in these logs "
            f"({', '.join(d.describe() for d in missing)} of what the thrusters give, at "
            f"least {100 * missing[0].threshold:g} % needed): their parameters were not "
            f"identified and keep the profile's values. Record an experiment of this stage "
            f"(trimd excite --stage {stage}) and fit that")
