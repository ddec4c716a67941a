"""Degenerate and hostile inputs to the ballast proposal, through the library and the CLI.

No static stability (W·z_g − B·z_b zero or negative: the passive trim is undefined),
little static stability (a level band far below what the pieces or the estimate
resolve), the solver's time limit, and covariances that are not covariances. Every
input must give an answer or a one-line error: never a traceback, a hang, or NaN in
the JSON.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.optimize import OptimizeResult

import trimd.ballast.stages as ballast_stages
from tests.ballast.test_ballast import estimate_for
from trimd.app.report import format_proposal
from trimd.ballast.check import equilibrium_attitude
from trimd.ballast.lp import ALLOWANCE_SHARE, build_programme, moment_resolution, piece_items
from trimd.ballast.propose import METHODS, Proposal, proposal_to_dict, propose_ballast
from trimd.cli.main import main
from trimd.core.errors import DataError
from trimd.core.estimate import StaticEstimate
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.profile import Profile
from trimd.drivers.sim.truth import passive_trim_deg

#: The audited estimate's 1σ of q = [W − B, m_x, m_y, m_z] [N, N·m].
Q_STD = (0.04, 0.097, 0.095, 0.306)
#: (net force W − B [N], net moment [N·m]) of the degenerate cases: zero moment and
#: 40 N heavy (floats needed for the window), negative m_z, small positive m_z.
CASES = {"zero": (40.0, (0.0, 0.0, 0.0)), "negative": (40.0, (1.0, 2.0, -5.0)),
         "small": (40.0, (-20.0, 10.0, 5.0))}


def with_net(profile: Profile, force_N: float, moment_Nm: tuple[float, float, float]
             ) -> StaticEstimate:
    """A consistent estimate of ``profile`` with the given net force and moment."""
    est = estimate_for(profile, [], Q_STD)
    q = np.r_[force_N, moment_Nm]
    W = est.buoyancy_N + force_N
    return dataclasses.replace(est, q=q, weight_N=W,
                               r_g_m=(q[1:] + est.buoyancy_N * est.r_b_m) / W)


def strict_json(text: str) -> Any:
    """json.loads that fails on NaN and Infinity, which are not JSON."""
    def reject(token: str) -> None:
        raise AssertionError(f"{token} in the JSON output")
    return json.loads(text, parse_constant=reject)


def assert_no_trim(p: Proposal) -> None:
    """An answer for a vehicle without static stability: best achievable, said plainly."""
    assert p.success and not p.feasible and not p.trim.stable
    assert p.binding[0].startswith("no static stability: W·z_g − B·z_b = ")
    assert "passive trim undefined" in p.binding[0]
    assert "passive roll and pitch undefined" in p.message
    d = strict_json(json.dumps(proposal_to_dict(p), allow_nan=False))
    assert d["predicted_roll_deg"] is None and d["predicted_pitch_deg"] is None
    assert d["predicted_trim_std_deg"] == [None, None]
    assert "passive trim      undefined: no static stability" in format_proposal(p)


def test_equilibrium_attitude_needs_static_stability() -> None:
    assert equilibrium_attitude(np.zeros(3)) is None
    assert equilibrium_attitude(np.array([1.0, 2.0, -5.0])) is None
    assert equilibrium_attitude(np.array([0.0, 0.0, 1e-3]), min_mz_Nm=1e-2) is None
    attitude = equilibrium_attitude(np.array([0.0, 0.0, 1e-3]))
    assert attitude is not None and np.all(np.isfinite(attitude[1]))


@pytest.mark.parametrize("case", ["zero", "negative"])
@pytest.mark.parametrize("method", METHODS)
def test_no_static_stability_gives_best_achievable(sabertooth: Profile, method: str,
                                                   case: str) -> None:
    """The moments are still balanced (to the estimate's resolution for whole pieces)."""
    est = with_net(sabertooth, *CASES[case])
    p = propose_ballast(est, sabertooth, method)
    assert_no_trim(p)
    tol = moment_resolution(est) if method == "milp" else 1e-6
    assert np.abs(p.trim.net_moment_Nm[:2]).max() <= tol + 1e-9
    if p.window_pct is not None:  # the window is still met ("cannot meet level" only)
        assert p.window_pct[0] - 1e-6 <= p.trim.net_buoyancy_pct <= p.window_pct[1] + 1e-6
        assert "cannot meet level;" in p.message


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_little_static_stability(sabertooth: Profile, method: str) -> None:
    """m_z = 5 N·m: the continuous methods level exactly; milp cannot within 0.25°, says
    why, and stops at its node budget."""
    est = with_net(sabertooth, *CASES["small"])
    p = propose_ballast(est, sabertooth, method)
    assert p.success and p.trim.stable
    assert math.isfinite(p.trim.roll_deg) and math.isfinite(p.trim.pitch_std_deg)
    strict_json(json.dumps(proposal_to_dict(p), allow_nan=False))
    if method == "milp":
        assert not p.feasible
        assert "no level proposal found within the exact search's limit" in p.message
        assert p.binding[-1].startswith("little static stability: W·z_g − B·z_b = 5 N·m, so "
                                        "0.25° needs the moments balanced to 0.022 N·m")
        assert np.abs(p.trim.net_moment_Nm[:2]).max() <= moment_resolution(est) + 0.022
    elif method == "general":
        assert p.feasible and abs(p.trim.roll_deg) < 1e-4 and abs(p.trim.pitch_deg) < 1e-4


@pytest.mark.parametrize(("m_z", "share"), [(5.0, 1.0), (467.0, ALLOWANCE_SHARE)])
def test_the_free_allowance_is_a_quarter_where_the_pieces_can_aim_near_level(
        sabertooth: Profile, m_z: float, share: float) -> None:
    """At 5 N·m the 0.25° band (0.022 N·m) and a quarter of 1σ are 1 % of the smallest
    piece's moment (2.2 N·m): the whole 1σ is free. At the bench's 467 N·m the band is
    2.0 N·m: a quarter."""
    est = with_net(sabertooth, 40.0, (-20.0, 10.0, m_z))
    items = piece_items(sabertooth)
    prog = build_programme(est, sabertooth, items, level_tol_deg=0.25, window_pct=None)
    free = prog.upper[len(items) + 4:len(items) + 6]
    assert free == pytest.approx([share * moment_resolution(est)] * 2)


def test_node_limit_before_any_solution(sabertooth: Profile,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """A stage that stops at its budget with no solution at all: nothing is proposed."""
    def no_solution_in_budget(c: Any, A: Any, b: Any, upper: Any, integrality: Any,
                              node_limit: int) -> OptimizeResult:
        return OptimizeResult(status=4, x=None, fun=None,
                              message="model_status is Node limit reached")

    monkeypatch.setattr(ballast_stages, "solve", no_solution_in_budget)
    p = propose_ballast(with_net(sabertooth, *CASES["small"]), sabertooth, "milp")
    assert not p.success and not p.feasible and p.added_mass_kg == 0.0
    assert p.message.startswith("no solution at the 'net-buoyancy window' stage: search "
                                "limit reached before any solution; nothing proposed.")


#: The estimate of a trim of the perturbed BlueROV2 Heavy, 0.4 kg at W-aft-stbd
#: (``bench_calibration``'s seed 54), q [N, N·m] and its covariance, to the last digit: the
#: window and level stages solve, and HiGHS calls the ballast stage, holding their optima
#: to 1e-7 + 1e-6 relative, infeasible (before the retry nothing was proposed).
SEED54_Q = [3.0694928575227944, -0.8832019478232292, 0.9093116753913149, 2.4271979784641933]
SEED54_Q_COV = [
    [0.19935582858229306, -0.0017836182660352208, 0.0007384895117000482, -0.01692667480028711],
    [-0.0017836182660352189, 0.0030180497338158007, -0.0025510928973575065,
     -0.004498470453202669],
    [0.0007384895117000472, -0.0025510928973575073, 0.004061697401021036, 0.00455969345525747],
    [-0.01692667480028711, -0.004498470453202672, 0.0045596934552574716, 0.020749929229946243]]


def test_a_stage_the_solver_calls_infeasible_is_solved_again_with_looser_holds(
        bluerov: Profile) -> None:
    """The earlier stages' solution meets every row held, so an infeasible later stage is
    the solver's tolerance: solved again with the optima held looser, it proposes ballast
    that brings the vehicle of that q within the window and the level tolerance
    (the simulator's passive trim, :func:`~trimd.drivers.sim.truth.passive_trim_deg`, of
    q plus the pieces' forces and moments)."""
    est = dataclasses.replace(with_net(bluerov, SEED54_Q[0], tuple(SEED54_Q[1:])),
                              q_cov=np.array(SEED54_Q_COV))
    p = propose_ballast(est, bluerov, "milp")
    assert p.success and p.feasible and p.pieces_handled > 0, p.message
    assert "not optimal" not in p.message
    print(f"{p.pieces_handled} pieces; {p.message}")
    q = np.array(SEED54_Q) + sum(
        (s.net_down_N * np.r_[1.0, s.position_m] for s in p.slots), np.zeros(4))
    roll, pitch = passive_trim_deg(q)
    assert max(abs(roll), abs(pitch)) <= bluerov.level_tol_deg, (roll, pitch)
    lo, hi = bluerov.net_buoyancy_pct
    assert lo <= -100 * q[0] / (est.buoyancy_N + q[0]) <= hi, q[0]


@pytest.mark.parametrize(("status", "solver_says", "message"), [
    (4, "model_status is Node limit reached",
     "search limit reached at the 'ballast' stage: best found, not proven optimal"),
    (2, "The problem is infeasible.",
     "the 'ballast' stage found no solution within the solver's tolerances: the previous "
     "stage's kept, not optimal for it")])
def test_a_stage_without_a_solution_keeps_the_previous_stages(
        sabertooth: Profile, monkeypatch: pytest.MonkeyPatch, status: int, solver_says: str,
        message: str) -> None:
    """A stage cut short with no solution of its own, or infeasible again when solved with
    the optima held looser, keeps the previous stage's solution (which meets every row held
    so far), and the message says so."""
    solve = ballast_stages.solve

    def ballast_stage_fails(c: Any, A: Any, b: Any, upper: Any, integrality: Any,
                            node_limit: int) -> OptimizeResult:
        if A.shape[0] == 20:  # 16 rows + window (2) + level held: the ballast stage
            return OptimizeResult(status=status, x=None, fun=None, message=solver_says)
        return solve(c, A, b, upper, integrality, node_limit)

    monkeypatch.setattr(ballast_stages, "solve", ballast_stage_fails)
    p = propose_ballast(with_net(sabertooth, *CASES["zero"]), sabertooth, "milp")
    assert p.success
    assert message in p.message
    assert_no_trim(p)


def write(tmp_path: Path, est: StaticEstimate, **override: Any) -> str:
    d = estimate_to_dict(est)
    d.update(override)
    path = tmp_path / "est.json"
    path.write_text(json.dumps(d))
    return str(path)


def ballast(path: str, *extra: str) -> int:
    return main(["ballast", "--profile", "sabertooth-dh2", "--estimate", path, *extra])


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("method", METHODS)
def test_cli_degenerate_json(tmp_path: Path, sabertooth: Profile,
                             capsys: pytest.CaptureFixture[str], method: str, case: str) -> None:
    path = write(tmp_path, with_net(sabertooth, *CASES[case]))
    assert ballast(path, "--method", method, "--json") == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    out = strict_json(captured.out)
    assert out["method"] == method and out["success"] is True
    if case == "small":
        assert isinstance(out["predicted_roll_deg"], float)
    else:
        assert out["feasible"] is False and out["predicted_roll_deg"] is None
        assert out["binding"][0].startswith("no static stability")


def test_cli_degenerate_table(tmp_path: Path, sabertooth: Profile,
                              capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, with_net(sabertooth, *CASES["zero"]))
    assert ballast(path, "--method", "lp") == 0
    out = capsys.readouterr().out
    assert out.startswith("ballast by lp: NOT FEASIBLE: best achievable")
    assert "passive trim      undefined: no static stability" in out
    assert "nan" not in out.lower()


NOT_PSD = (-np.eye(4)).tolist()
ASYMMETRIC = (np.eye(4) + np.triu(np.ones((4, 4)), 1) * 0.1).tolist()


@pytest.mark.parametrize(("key", "value", "message"), [
    ("cov_net", NOT_PSD, "'cov_net' is not positive semi-definite (eigenvalue -1)"),
    ("cov_net", ASYMMETRIC, "'cov_net' is not symmetric"),
    ("cov_net", [[math.nan] * 4] * 4, "'cov_net' must be (4, 4) finite numbers"),
    ("cov_net", [[1.0, 0.0], [0.0, 1.0]], "'cov_net' must be (4, 4) finite numbers"),
    ("cov_W_cg", NOT_PSD, "'cov_W_cg' is not positive semi-definite"),
])
def test_cli_bad_covariance(tmp_path: Path, sabertooth: Profile,
                            capsys: pytest.CaptureFixture[str], key: str, value: Any,
                            message: str) -> None:
    path = write(tmp_path, estimate_for(sabertooth, []), **{key: value})
    assert ballast(path, "--json") == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    # --json: the same line as one error object on stdout, and nothing else there
    assert [json.loads(line) for line in captured.out.splitlines()] == [
        {"type": "error", "message": err[0], "exit_code": 2}]


def test_cli_bad_node_limit(tmp_path: Path, sabertooth: Profile,
                            capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, estimate_for(sabertooth, []))
    assert ballast(path, "--node-limit", "0") == 2
    assert "expected an integer ≥ 1, got '0'" in capsys.readouterr().err


@pytest.mark.parametrize("method", METHODS)
def test_library_rejects_a_covariance_that_is_not_one(sabertooth: Profile, method: str
                                                      ) -> None:
    est = dataclasses.replace(estimate_for(sabertooth, []), q_cov=-np.eye(4))
    with pytest.raises(DataError, match="covariance of the net quantities is not positive "
                                        "semi-definite"):
        propose_ballast(est, sabertooth, method)
    with pytest.raises(DataError, match="weight must be positive"):
        propose_ballast(dataclasses.replace(est, weight_N=0.0), sabertooth, method)
