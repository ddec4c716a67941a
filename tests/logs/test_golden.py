"""The golden recording replays to its recorded result: a regression anchor that does not
depend on the simulator (tests/data/golden/README.md)."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest
import yaml

from tests.helpers import REPO
from trimd.cli.main import main
from trimd.core.effort import tau_at
from trimd.core.estimate import estimate_static
from trimd.core.holdfinder import find_holds
from trimd.core.profile_yaml import parse_profile
from trimd.core.samples import Attitude, Thrusters
from trimd.logs.replay import ReplayLink, recorded_profile_yaml

GOLDEN = REPO / "tests" / "data" / "golden"
TRUTH_CG_MM = (-8.635, 5.025, 0.0)


def test_the_golden_recording_replays_to_its_result(capsys: pytest.CaptureFixture[str]
                                                    ) -> None:
    expected = json.loads((GOLDEN / "sabertooth-10kg-aftsb.expected.json").read_text())
    assert main(["replay", str(GOLDEN / "sabertooth-10kg-aftsb.tlog"), "--json"]) == 0
    got = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    est, want = got["estimate"], expected["estimate"]
    for key in ("weight_N", "m_ext_kg", "m_ext_std_kg", "net_force_N"):
        assert est[key] == pytest.approx(want[key], rel=1e-9, abs=1e-12), key
    for key in ("cg_m", "cg_std_m", "net_moment_Nm"):
        assert est[key] == pytest.approx(want[key], rel=1e-9, abs=1e-12), key
    assert got["proposal"]["slots"] == expected["proposal"]["slots"]
    # and the anchor itself is right: the thesis case within its own ± (3σ)
    assert abs(est["m_ext_kg"] - 10.0) < 3 * est["m_ext_std_kg"]
    for truth, cg, sd in zip(TRUTH_CG_MM, est["cg_m"], est["cg_std_m"], strict=True):
        assert abs(cg * 1e3 - truth) < 3 * sd * 1e3 + 0.01



def test_the_golden_recording_thinned_to_ground_station_rates_finds_both_holds() -> None:
    """Thinned to 4 Hz attitude and 2 Hz thrusters, as a ground station's log would be,
    and read as a foreign log (no recorded procedure: holds found by the live settling
    test), the recording gives both holds and the live estimate within 3σ of the two
    estimates' difference. (The batch detector found one hold.) Which sample of each
    0.5 s the thinning keeps moves W·x_g − B·x_b by ±3.5 N·m (σ 1.2–1.5 N·m): the
    level hold is worth only ~10 independent samples at these rates."""
    attitude_hz, thruster_hz = 4.0, 2.0
    path = GOLDEN / "sabertooth-10kg-aftsb.tlog"
    text = recorded_profile_yaml(path)
    assert text is not None
    profile = parse_profile(yaml.safe_load(text), "recorded")
    samples = list(ReplayLink(str(path), profile).read_samples())

    def thinned(kind: type, hz: float) -> list[Any]:
        kept, slot = [], -1
        for s in samples:
            if isinstance(s, kind) and math.floor(s.t_s * hz) != slot:
                slot = math.floor(s.t_s * hz)
                kept.append(s)
        return kept

    thrusters = thinned(Thrusters, thruster_hz)
    t = np.array([s.t_s for s in thrusters])
    tau, ok = tau_at(profile, t, thrusters)
    holds = find_holds(thinned(Attitude, attitude_hz), t[ok], tau[ok], profile)
    assert len(holds) == 2
    est = estimate_static(holds, profile)
    live = json.loads((GOLDEN / "sabertooth-10kg-aftsb.expected.json").read_text())["estimate"]
    assert abs(est.m_ext_kg - live["m_ext_kg"]) < 3 * np.hypot(est.m_ext_std_kg,
                                                               live["m_ext_std_kg"])
    np.testing.assert_array_less(np.abs(est.r_g_m - live["cg_m"]),
                                 3 * np.hypot(est.r_g_std_m, live["cg_std_m"]))
