"""Profile loading: the shipped profiles load; every user error names file, key, problem."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from tests.helpers import PROFILES
from trimd.core.errors import ProfileError
from trimd.core.model import thrust_configuration
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.profile_yaml import load_profile, parse_profile

SABERTOOTH = PROFILES / "sabertooth-dh2.yaml"


def raw() -> dict[str, Any]:
    data: dict[str, Any] = yaml.safe_load(SABERTOOTH.read_text())
    return copy.deepcopy(data)


def test_shipped_profiles_load(sabertooth: Profile, bluerov: Profile) -> None:
    assert sabertooth.mass_kg == 1184.0
    assert [s.name for s in sabertooth.slots] == ["AftSB", "AftP", "FrontSB", "FrontP"]
    assert [(h.roll_deg, h.pitch_deg) for h in sabertooth.holds] == [(0, 0), (20, 20)]
    assert len(bluerov.thrusters) == 8 and bluerov.frame_config == 2
    assert bluerov.buoyancy_N == pytest.approx(1025 * 9.81 * 0.0134)


def test_thrust_curve_uncertainty_and_station_keeping_defaults(sabertooth: Profile) -> None:
    data = raw()
    del data["thrust_curves"]["sabertooth"]["uncertainty_pct"]
    assert parse_profile(data).thrusters[0].curve.uncertainty_pct == 5.0
    assert sabertooth.thrusters[0].curve.uncertainty_pct == 5.0
    assert not sabertooth.holds_station and parse_profile(data | {"holds_station": True}
                                                          ).holds_station


def test_load_by_name_finds_shipped_profile() -> None:
    assert load_profile("bluerov2-heavy").name == "bluerov2-heavy"


def test_bluerov_directions_follow_ardusub_factor_table(bluerov: Profile) -> None:
    """AP_Motors6DOF vectored 6-DOF: roll, pitch, yaw, throttle, forward, lateral factors."""
    factors = np.array([
        [0, 0, 1, 0, -1, 1], [0, 0, -1, 0, -1, -1], [0, 0, -1, 0, 1, 1], [0, 0, 1, 0, 1, -1],
        [1, -1, 0, -1, 0, 0], [-1, -1, 0, -1, 0, 0], [1, 1, 0, -1, 0, 0], [-1, 1, 0, -1, 0, 0],
    ])
    T = thrust_configuration(bluerov.thrusters)
    # a positive output produces body force (forward, lateral, -throttle) ...
    np.testing.assert_allclose(np.sign(np.round(T[:3], 6)).T,
                               np.column_stack([factors[:, 4], factors[:, 5], -factors[:, 3]]))
    # ... and roll / pitch / yaw moments of the factor's sign (the verticals' roll and
    # pitch, the horizontals' yaw)
    np.testing.assert_array_equal(np.sign(T[3, 4:]), factors[4:, 0])
    np.testing.assert_array_equal(np.sign(T[4, 4:]), factors[4:, 1])
    np.testing.assert_array_equal(np.sign(T[5, :4]), factors[:4, 2])


@pytest.mark.parametrize(("edit", "message"), [
    (lambda d: d.pop("mass_kg"), r"mass_kg: missing"),
    (lambda d: d.update(mass_kg="heavy"), r"mass_kg: expected a finite number"),
    (lambda d: d.update(mass_lb=2000, mass_kg=1), r"mass_lb: unknown key \(did you mean 'mass_kg'"),
    (lambda d: d["thrusters"][2].update(direction=[0, 0, 2]),
     r"thrusters\[2\]\.direction: expected a unit vector"),
    (lambda d: d["thrusters"][0].update(curve="t300"), r"thrusters\[0\]\.curve: unknown thrust"),
    (lambda d: d["thrusters"][1].update(channel=1), r"share an output channel"),
    (lambda d: d["thrusters"][1].update(channel=0), r"thrusters\[1\]\.channel: expected a number"),
    (lambda d: d["buoyancy"].update(volume_m3=1.0), r"buoyancy\.force_N: give exactly one"),
    (lambda d: d["holds"][1].update(roll_deg=40), r"holds\[1\]\.roll_deg: 40"),
    (lambda d: d["damping"]["linear"].update(surge=100), r"damping\.linear\.surge: damping"),
    (lambda d: d["ballast"]["slots"][0].pop("max_weight_kg"),
     r"ballast\.slots\[0\]\.max_weight_kg: missing"),
    (lambda d: d["ballast"]["inventory"][0].update(volume_m3=0.01), r"a weight must sink"),
    (lambda d: d["ballast"].update(net_buoyancy_pct=[2, 1]), r"net_buoyancy_pct"),
    (lambda d: d["thrust_curves"]["sabertooth"]["tables"][0].update(
        pwm_us=[1100, 1300, 1490, 1510, 1900, 1700]), r"strictly increasing"),
    (lambda d: d["procedure"].update(max_tilt_deg=80), r"max_tilt_deg: expected less than 60"),
    (lambda d: d["procedure"].update(tilt_rate_deg_s=0),
     r"procedure\.tilt_rate_deg_s: expected a positive number, got 0"),
    (lambda d: d["procedure"].update(tilt_rate_deg_sec=5),
     r"procedure\.tilt_rate_deg_sec: unknown key \(did you mean 'tilt_rate_deg_s'\?\)"),
    (lambda d: d["thrust_curves"]["sabertooth"].update(uncertainty_pct=-1),
     r"thrust_curves\.sabertooth\.uncertainty_pct: expected a number >= 0"),
    (lambda d: d["thrust_curves"]["sabertooth"].update(uncertainty_pct=100),
     r"thrust_curves\.sabertooth\.uncertainty_pct: expected a relative standard deviation"),
    (lambda d: d.update(frame_config="heavy"), r"frame_config: expected"),
    (lambda d: d.update(holds_station="yes"), r"holds_station: expected true or false"),
    (lambda d: d["ballast"]["slots"][0].update(max_wieght_kg=d["ballast"]["slots"][0].pop(
        "max_weight_kg")), r"max_weight_kg: missing \(required\); is 'max_wieght_kg' a typo"),
    (lambda d: d["thrust_curves"]["sabertooth"]["tables"][0].update(
        thrust_N=d["thrust_curves"]["sabertooth"]["tables"][0]["thrust_N"][::-1]),
     r"tables\[0\]\.thrust_N: expected thrust that never falls as PWM rises"),
    (lambda d: d["ballast"]["slots"][1].update(name="AftSB"),
     r"ballast\.slots: expected unique names, got AftSB twice"),
    (lambda d: d.update(holds=[{"roll_deg": 0, "pitch_deg": 0}] * 2),
     r"holds: expected at least two holds at different attitudes, one of them tilted"),
    (lambda d: d.update(holds=[{"roll_deg": 20, "pitch_deg": 20}]), r"holds: expected"),
    (lambda d: d["ballast"].update(installed=[{"slot": "AftSBB", "piece": "lead-1kg",
                                               "count": 1}]),
     r"ballast\.installed\[0\]: no ballast slot 'AftSBB' \(did you mean 'AftSB'\?"),
    (lambda d: d["ballast"].update(installed=[{"slot": "AftSB", "piece": "lead-1kgg",
                                               "count": 1}]),
     r"ballast\.installed\[0\]: no inventory piece 'lead-1kgg' \(did you mean 'lead-1kg'\?"),
    (lambda d: d["ballast"].update(installed=[{"slot": "AftSB", "piece": "lead-1kg",
                                               "count": 11}]),
     r"ballast\.installed: slot AftSB takes 10 kg of weight; 11 kg installed"),
    (lambda d: d["ballast"].update(installed=[{"slot": "AftSB", "piece": "lead-1kg",
                                               "count": -1}]),
     r"ballast\.installed\[0\]\.count: expected a number >= 0"),
    (lambda d: d["ballast"].update(installed=[{"slot": "AftSB", "piece": "lead-1kg",
                                               "cuont": 1}]),
     r"ballast\.installed\[0\]\.count: missing \(required\); is 'cuont' a typo"),
])
def test_errors_name_file_key_and_expectation(edit: Any, message: str) -> None:
    data = raw()
    edit(data)
    with pytest.raises(ProfileError, match=message) as info:
        parse_profile(data, "vehicle.yaml")
    assert str(info.value).startswith("vehicle.yaml: ")


def test_unreadable_and_invalid_files(tmp_path: Path) -> None:
    with pytest.raises(ProfileError, match="cannot read profile"):
        load_profile(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    with pytest.raises(ProfileError, match="not valid YAML"):
        load_profile(bad)
    bad.write_text("- just a list\n")
    with pytest.raises(ProfileError, match="expected a mapping"):
        load_profile(bad)


def test_thrust_given_in_kgf_is_converted(bluerov: Profile) -> None:
    table = bluerov.thrusters[0].curve.tables[1]
    assert table.voltage_V == 16.0
    assert table.thrust_N[-1] == pytest.approx(5.25 * 9.80665)


def test_installed_ballast_is_read_merged_and_spelled_as_the_profile() -> None:
    data = raw()
    data["ballast"]["installed"] = [{"slot": "aftsb", "piece": "lead-1kg", "count": 2},
                                    {"slot": "AftSB", "piece": "LEAD-1kg", "count": 1},
                                    {"slot": "FrontP", "piece": "foam-2kg", "count": 0}]
    profile = parse_profile(data, "vehicle.yaml")
    assert profile.installed == (InstalledPiece("AftSB", "lead-1kg", 3),)
    assert parse_profile(raw(), "vehicle.yaml").installed == ()
