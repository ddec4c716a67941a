"""Each driver classes its own mode vocabulary (trimd.core.samples.ModeClass): ArduSub's
mode numbers (MAVLink, tlog replay, DataFlash), a serial vehicle's STA tokens, the
simulator's modes."""

from __future__ import annotations

import pytest

from trimd.core.samples import Health, ModeClass
from trimd.drivers.mavlink import ardusub
from trimd.drivers.serial.modes import MODE_CLASSES as SERIAL_CLASSES
from trimd.drivers.serial.protocol import VEHICLE, LineParser, checksum, to_sample
from trimd.drivers.sim.controller import MODE_CLASSES as SIM_CLASSES
from trimd.drivers.sim.controller import MODES as SIM_MODES

ARDUSUB = {
    "MANUAL": ModeClass.MANUAL, "ACRO": ModeClass.MANUAL,
    "STABILIZE": ModeClass.STABILISED,
    "ALT_HOLD": ModeClass.DEPTH_HOLDING, "POSHOLD": ModeClass.DEPTH_HOLDING,
    "AUTO": ModeClass.AUTONOMOUS, "GUIDED": ModeClass.AUTONOMOUS,
    "CIRCLE": ModeClass.AUTONOMOUS, "SURFTRAK": ModeClass.AUTONOMOUS,
    "SURFACE": ModeClass.FAILSAFE, "MOTOR_DETECT": ModeClass.SERVICE,
}


@pytest.mark.parametrize(("name", "expected"), ARDUSUB.items())
def test_ardusub_mode_numbers(name: str, expected: ModeClass) -> None:
    number = ardusub.mode_number(name)
    assert ardusub.mode_class(number) is expected
    assert ardusub.mode_class_of(name) is expected
    assert ardusub.mode_class_of(f"MODE{number}") is expected


def test_every_ardusub_mode_is_classed_and_others_are_unknown() -> None:
    assert set(ardusub.MODE_CLASSES) == set(ardusub.MODES)
    assert ardusub.mode_class(42) is ModeClass.UNKNOWN
    assert ardusub.mode_class_of("MODE42") is ModeClass.UNKNOWN
    assert ardusub.mode_class_of("NO_SUCH_MODE") is ModeClass.UNKNOWN


def test_serial_tokens_mean_what_the_same_ardusub_names_do() -> None:
    """A recording stores a serial vehicle's mode as ArduSub's number of the same name:
    the class must survive the round trip."""
    for token, mode_class in SERIAL_CLASSES.items():
        assert ardusub.mode_class_of(token) is mode_class, token


@pytest.mark.parametrize(("token", "expected"), [
    ("MANUAL", ModeClass.MANUAL), ("STABILIZE", ModeClass.STABILISED),
    ("ALT_HOLD", ModeClass.DEPTH_HOLDING), ("AUTO", ModeClass.AUTONOMOUS),
    ("SURFACE", ModeClass.FAILSAFE), ("MY_OWN_MODE", ModeClass.UNKNOWN),
])
def test_a_serial_status_sentence_carries_its_class(token: str, expected: ModeClass
                                                    ) -> None:
    body = f"VHSTA,5,{token},1,HOLD".encode()
    (sentence,) = LineParser(VEHICLE).feed(b"$%s*%02X\r\n" % (body, checksum(body)))
    health = to_sample(sentence, 5.0, (1, 2))
    assert isinstance(health, Health) and health.mode == token
    assert health.mode_class is expected


def test_the_simulator_classes_each_mode_it_flies_as_ardusub_does() -> None:
    assert set(SIM_CLASSES) == set(SIM_MODES)
    for mode, mode_class in SIM_CLASSES.items():
        assert ardusub.mode_class_of(mode) is mode_class
