"""The one precheck (trimd.core.precheck) judges the mode by its class, never its name."""

from __future__ import annotations

import pytest

from trimd.core.precheck import BUSY_CLASSES, Precheck
from trimd.core.samples import Depth, Health, ModeClass


def _problems(health: Health) -> list[str]:
    check = Precheck({"depth": 1.0}, max_depth_excursion_m=2.0)
    for k in range(60):
        check.sample(Depth(0.1 * k, 10.0))
    check.sample(health)
    return check.problems(5.9)


@pytest.mark.parametrize("mode_class", list(ModeClass))
def test_the_mode_class_alone_decides(mode_class: ModeClass) -> None:
    """A mode named ALT_HOLD that its driver classed autonomous is refused; one named
    AUTO that its driver classed manual is not: the name is for people."""
    for name in ("ALT_HOLD", "AUTO", "X"):
        problems = _problems(Health(5.0, True, name, True, mode_class=mode_class))
        refused = [p for p in problems if p.startswith(f"vehicle in {name} ")]
        assert bool(refused) == (mode_class in BUSY_CLASSES), (name, problems)


def test_autonomous_failsafe_and_service_are_refused_the_pilot_s_modes_are_not() -> None:
    assert {ModeClass.AUTONOMOUS, ModeClass.FAILSAFE, ModeClass.SERVICE} == BUSY_CLASSES
    for ok in (ModeClass.MANUAL, ModeClass.STABILISED, ModeClass.DEPTH_HOLDING):
        assert _problems(Health(5.0, True, "M", True, mode_class=ok)) == []


def test_arming_disarmed_and_unknown() -> None:
    assert _problems(Health(5.0, True, "MANUAL", False, mode_class=ModeClass.MANUAL)) == [
        "vehicle disarmed: arm it"]
    assert _problems(Health(5.0, True, "MANUAL", None, mode_class=ModeClass.MANUAL)) == [
        "the vehicle does not say whether it is armed"]
