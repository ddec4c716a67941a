"""The golden recording replays to its recorded result: a regression anchor that does not
depend on the simulator (tests/data/golden/README.md)."""

from __future__ import annotations

import json

import pytest

from tests.helpers import REPO
from trimd.cli.main import main

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

