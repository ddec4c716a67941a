"""`trimd solve`: CSV in every accepted form, and one clear message for every bad file."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import PROFILES, REPO, equilibrium_holds, payload_truth
from trimd.cli.main import main
from trimd.core.estimate import HoldSamples
from trimd.core.model import pwm_from_thrust, thrust_configuration
from trimd.core.profile import Profile

TAU_HEADER = "time_s,roll_deg,pitch_deg,X_N,Y_N,Z_N,K_Nm,M_Nm,N_Nm"


def write_csv(path: Path, holds: list[HoldSamples], *, hold_column: bool = False,
              gap_s: float = 30.0) -> Path:
    rows = []
    t0 = 0.0
    for k, h in enumerate(holds):
        t = t0 + (h.t_s - h.t_s[0])
        cols = [t, np.degrees(h.phi), np.degrees(h.theta), h.tau]
        if hold_column:
            cols.append(np.full(len(t), k))
        rows.append(np.column_stack(cols))
        t0 = t[-1] + gap_s
    header = TAU_HEADER + (",hold" if hold_column else "")
    np.savetxt(path, np.vstack(rows), delimiter=",", header=header, comments="", fmt="%.9g")
    return path


def run_json(capsys: pytest.CaptureFixture[str], *args: str) -> dict[str, object]:
    assert main([*args, "--json"]) == 0
    out: dict[str, object] = json.loads(capsys.readouterr().out)
    return out


@pytest.fixture
def thesis_holds(sabertooth: Profile) -> list[HoldSamples]:
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    return equilibrium_holds(sabertooth, W, r_g, n=300, attitude_noise_deg=0.05,
                             thrust_noise=0.01, rng=np.random.default_rng(3))


def test_solve_groups_holds_by_steady_state(tmp_path: Path, thesis_holds: list[HoldSamples],
                                            capsys: pytest.CaptureFixture[str]) -> None:
    path = write_csv(tmp_path / "h.csv", thesis_holds)
    out = run_json(capsys, "solve", str(path), "--profile", "sabertooth-dh2")
    assert len(out["holds"]) == 2  # type: ignore[arg-type]
    assert abs(out["m_ext_kg"] - 10.0) < 4 * out["m_ext_std_kg"]  # type: ignore[operator]
    np.testing.assert_allclose(out["cg_m"], [-0.0086348, 0.0050251, 0.0], atol=5e-5)
    for key in ("weight_N", "buoyancy_N", "m_ext_std_kg", "cg_std_m", "net_moment_Nm"):
        assert key in out


def test_a_spreadsheet_csv_with_a_byte_order_mark_reads(
        tmp_path: Path, thesis_holds: list[HoldSamples],
        capsys: pytest.CaptureFixture[str]) -> None:
    plain = write_csv(tmp_path / "h.csv", thesis_holds, hold_column=True)
    bom = tmp_path / "excel.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    assert run_json(capsys, "solve", str(bom), "--profile", "sabertooth-dh2") == run_json(
        capsys, "solve", str(plain), "--profile", "sabertooth-dh2")


@pytest.mark.parametrize("battery", [False, True])
def test_solve_with_hold_column_and_pwm(tmp_path: Path, bluerov: Profile, battery: bool,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    """Per-thruster PWM columns go through the profile's curves and geometry, at the
    nominal voltage or at each row's ``battery_V`` (between the 12 V and 16 V tables)."""
    W, r_g = payload_truth(bluerov, 0.4, np.array([0.11, 0.128, 0.175]))
    holds = equilibrium_holds(bluerov, W, r_g, n=50)
    T = thrust_configuration(bluerov.thrusters)
    lines = ["time_s,roll_deg,pitch_deg,hold," + ",".join(f"pwm_{i}" for i in range(1, 9))
             + (",battery_V" if battery else "")]
    for k, h in enumerate(holds):
        f = np.linalg.lstsq(T, h.tau[0], rcond=None)[0]
        for i in range(len(h.t_s)):
            volts = 15.5 - 0.5 * k - 0.02 * i if battery else 16.0
            pwm = [pwm_from_thrust(t.curve, [fi], volts)[0] for t, fi in zip(
                bluerov.thrusters, f, strict=True)]
            lines.append(",".join(f"{v:.9g}" for v in (
                i * 0.1 + 100 * k, np.degrees(h.phi[i]), np.degrees(h.theta[i]), k, *pwm,
                *([volts] if battery else []))))
    path = tmp_path / "pwm.csv"
    path.write_text("\n".join(lines) + "\n")
    # the holds balance g(η) exactly: a vehicle that holds station (no drift to correct)
    profile = tmp_path / "heavy.yaml"
    # (and no dead-band margin: its share is test_intervals_cover_thrust_map_errors')
    text = (PROFILES / "bluerov2-heavy.yaml").read_text().replace(
        "uncertainty_pct: 5.0", "uncertainty_pct: 5.0\n    deadband_margin_us: 0.0")
    profile.write_text(text + "holds_station: true\n")
    out = run_json(capsys, "solve", str(path), "--profile", str(profile))
    assert out["m_ext_kg"] == pytest.approx(0.4, abs=1e-6)
    np.testing.assert_allclose(out["cg_m"], r_g, atol=1e-7)
    # noise-free, yet the curves' 5 % is in the ±: from the level hold's Z row alone σ
    # would be that of Σ_i T_Z,i·f_i with each f_i 5 % uncertain; a vehicle that holds
    # station adds the tilted hold's force rows, which can only narrow it
    f_level = np.linalg.lstsq(T, holds[0].tau[0], rcond=None)[0]
    level_only = 0.05 * float(np.linalg.norm(T[2] * f_level))
    assert 0.3 * level_only < out["weight_std_N"] <= level_only * (1 + 1e-6)


def test_human_output(tmp_path: Path, thesis_holds: list[HoldSamples],
                      capsys: pytest.CaptureFixture[str]) -> None:
    path = write_csv(tmp_path / "h.csv", thesis_holds, hold_column=True)
    assert main(["solve", str(path), "--profile", "sabertooth-dh2"]) == 0
    text = capsys.readouterr().out
    assert "extra mass m_ext" in text and "z_g" in text


@pytest.mark.parametrize(("content", "message"), [
    ("time_s,roll_deg,X_N\n0,0,0\n", "missing column"),
    ("", "empty file"),
    (TAU_HEADER + "\n0,0,0,1,2,3,4,5,nan\n", "NaN or infinite"),
    (TAU_HEADER + "\n0,0,0,1,2,3,4,5,x\n", "not a number"),
    (TAU_HEADER + "\n0,0,0,1,2,3\n", "6 fields, header has 9"),
    ("time_s,roll_deg,pitch_deg\n0,0,0\n1,0,0\n", "missing columns: give X_N"),
])
def test_bad_files_exit_2_with_one_line(tmp_path: Path, content: str, message: str,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(content)
    assert main(["solve", str(path), "--profile", "sabertooth-dh2"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_no_steady_hold_and_level_only(tmp_path: Path, sabertooth: Profile,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    t = np.arange(400) * 0.1
    ramp = np.column_stack([t, t * 0.1, t * 0.1, *(np.outer(np.ones(6), t))])
    path = tmp_path / "ramp.csv"
    np.savetxt(path, ramp, delimiter=",", header=TAU_HEADER, comments="")
    assert main(["solve", str(path), "--profile", "sabertooth-dh2"]) == 2
    assert "no steady hold" in capsys.readouterr().err
    W, r_g = payload_truth(sabertooth, 5.0, np.array([0.78, 0.6, 0.0]))
    level = equilibrium_holds(sabertooth, W, r_g, tilts_deg=((0, 0),), n=300,
                              attitude_noise_deg=0.05, thrust_noise=0.01)
    path = write_csv(tmp_path / "level.csv", level)
    assert main(["solve", str(path), "--profile", "sabertooth-dh2"]) == 2
    assert "z_g is not identifiable" in capsys.readouterr().err


@pytest.mark.slow
def test_missing_file_and_bad_profile_without_traceback(tmp_path: Path) -> None:
    bad_profile = tmp_path / "p.yaml"
    bad_profile.write_text("name: x\nmass_kgs: 3\n")
    for args in (["solve", str(tmp_path / "none.csv"), "--profile", "sabertooth-dh2"],
                 ["solve", str(tmp_path / "none.csv"), "--profile", str(bad_profile)]):
        proc = subprocess.run([sys.executable, "-m", "trimd", *args], cwd=REPO,
                              capture_output=True, text=True, check=False)
        assert proc.returncode == 2
        assert proc.stderr.startswith("trimd: error: ") and "Traceback" not in proc.stderr


def test_estimate_json_round_trip_and_bad_holds(tmp_path: Path, thesis_holds: list[HoldSamples],
                                                sabertooth: Profile) -> None:
    from trimd.core.errors import DataError
    from trimd.core.estimate import estimate_static
    from trimd.core.estimate_json import estimate_from_dict, estimate_to_dict

    d = estimate_to_dict(estimate_static(thesis_holds, sabertooth))
    back = estimate_to_dict(estimate_from_dict(json.loads(json.dumps(d))))
    assert back == d
    d["holds"] = [{"roll_deg": 1}]
    with pytest.raises(DataError, match="malformed 'holds'"):
        estimate_from_dict(d)


def test_solve_with_ballast_levels_the_vehicle(tmp_path: Path, thesis_holds: list[HoldSamples],
                                               capsys: pytest.CaptureFixture[str]) -> None:
    path = write_csv(tmp_path / "h.csv", thesis_holds)
    out = run_json(capsys, "solve", str(path), "--profile", "sabertooth-dh2", "--ballast")
    ballast = out["ballast"]
    assert ballast["method"] == "milp"  # type: ignore[index]
    assert abs(ballast["predicted_roll_deg"]) < 0.5  # type: ignore[index]
    assert abs(ballast["predicted_pitch_deg"]) < 0.5  # type: ignore[index]
    assert main(["solve", str(path), "--profile", "sabertooth-dh2", "--ballast", "lp"]) == 0
    assert "lp" in capsys.readouterr().out
