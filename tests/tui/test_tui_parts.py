"""The TUI's pure parts: braille plot, top view, live state, thruster effort, report."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.ballast.test_ballast_degenerate import CASES, with_net
from tests.helpers import equilibrium_holds, payload_truth
from trimd.ballast.propose import propose_ballast
from trimd.core.estimate import estimate_static
from trimd.core.profile import InstalledPiece, Profile
from trimd.core.samples import Attitude, Depth, Health, HoldAttitude, Release
from trimd.tui.plot import Series, braille_plot
from trimd.tui.report import Report, save_report
from trimd.tui.result_panel import ResultPanel
from trimd.tui.telemetry import HISTORY_S, LiveState
from trimd.tui.thrusters import efforts
from trimd.tui.topview import top_view


def test_braille_plot_draws_lines_on_the_dot_grid() -> None:
    # 2 cells wide (4 dots), 1 row (4 dots), y from 0 to 3: y = 0 is the bottom dot row
    flat = braille_plot([Series([0.0, 1.0], [0.0, 0.0], "red")], width=8, height=1,
                        x_range=(0.0, 1.0), y_lim=(0.0, 3.0))
    assert flat.plain == "  3.0│⣀⣀"
    rising = braille_plot([Series([0.0, 1.0], [0.0, 3.0], "red")], width=8, height=1,
                          x_range=(0.0, 1.0), y_lim=(0.0, 3.0))
    assert rising.plain == "  3.0│⡠⠊"  # (0,3) (1,2) | (2,1) (3,0): one dot per column
    gap = braille_plot([Series([0.0, 0.5, 1.0], [3.0, math.nan, 3.0], "red")], width=8,
                       height=1, x_range=(0.0, 1.0), y_lim=(0.0, 3.0))
    assert gap.plain == "  3.0│⠁⠈"  # NaN breaks the line: only the two end points


def test_a_reversed_y_axis_draws_depth_deeper_lower_down() -> None:
    def row_of(depth_m: float) -> int:
        rows = braille_plot([Series([0.0, 1.0], [depth_m, depth_m], "yellow")], width=8,
                            height=3, x_range=(0.0, 1.0), y_lim=(10.12, 9.88)).plain.split("\n")
        (row,) = [k for k, line in enumerate(rows) if line[6:].strip("\u2800")]
        return row

    assert (row_of(9.9), row_of(10.0), row_of(10.1)) == (0, 1, 2)


def test_top_view_places_slots_and_the_cg_arrow(sabertooth: Profile) -> None:
    _, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    *lines, legend = top_view(sabertooth, width=41, height=22,
                              cg_m=(r_g[0], r_g[1])).plain.split("\n")

    def where(ch: str) -> tuple[int, int]:
        (pos,) = [(r, c) for r, line in enumerate(lines) for c, x in enumerate(line) if x == ch]
        return pos

    r0, c0 = where("+")
    for i, s in enumerate(sabertooth.slots):  # forward is up, starboard is right
        r, c = where("ABCD"[i])
        assert (r < r0) == (s.position_m[0] > 0) and (c > c0) == (s.position_m[1] > 0)
    r1, c1 = where("●")  # 10 kg aft starboard: CG1 lies aft and to starboard of CG0
    assert r1 > r0 and c1 > c0
    assert legend == "+ CG0  ● CG1 (shift ×50)"


def test_live_state_rates_history_setpoint_and_heartbeat() -> None:
    now = [0.0]
    state = LiveState(clock=lambda: now[0])
    assert state.heartbeat_age_s() is None
    for k in range(1, 20 * 90 + 1):  # 90 s of attitude at 20 Hz, depth at 5 Hz
        t = k / 20
        state.sample(Attitude(t, 0.1, 0.0, 0.0, 0, 0, 0))
        if k % 4 == 0:
            state.sample(Depth(t, 12.0))
    state.sample(Health(90.0, True, "ALT_HOLD", True))
    assert state.rate_hz("att") == pytest.approx(20.0)
    assert state.rate_hz("depth") == pytest.approx(5.0)
    ts = [p.t_s for p in state.history]
    assert ts[-1] - ts[0] <= HISTORY_S and min(np.diff(ts)) >= 0.2 - 1e-9
    assert state.history[-1].roll_deg == pytest.approx(math.degrees(0.1))
    now[0] = 2.5
    assert state.heartbeat_age_s() == 2.5
    state.command(HoldAttitude(0.0, math.radians(20), 0.0))
    assert state.setpoint is not None and state.setpoint.pitch_deg == pytest.approx(20)
    assert state.setpoint.depth_m == 12.0  # depth is held where the vehicle is
    state.command(Release())
    assert state.setpoint is None


def test_thruster_effort_is_the_fraction_of_the_thrust_available(sabertooth: Profile) -> None:
    # Sabertooth curve: −500 N at 1100 µs, 0 in 1490–1510, 260 N at 1700, 600 N at 1900
    pwm = (1900.0, 1100.0, 1500.0, 1700.0, 1300.0, 2000.0)
    assert efforts(sabertooth, pwm, 48.0) == pytest.approx(
        [1.0, -1.0, 0.0, 260 / 600, -220 / 500, 1.0])


def test_report_files_never_overwrite(sabertooth: Profile, tmp_path: Path) -> None:
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    est = estimate_static(equilibrium_holds(sabertooth, W, r_g), sabertooth)
    proposal = propose_ballast(est, sabertooth, method="line")
    report = Report("sabertooth-dh2", "sim", "done: trim estimate ready", None, est, proposal,
                    "10 kg at AftSB", [(math.nan, "info", "confirmed"), (1.5, "state", "a|b")])
    md, js = save_report(report, tmp_path, "r")
    md2, js2 = save_report(report, tmp_path, "r")
    assert (md.name, js.name, md2.name, js2.name) == ("r.md", "r.json", "r-2.md", "r-2.json")
    data = json.loads(js.read_text())
    assert data["estimate"]["m_ext_kg"] == pytest.approx(est.m_ext_kg)
    assert data["proposal"]["method"] == "line"
    assert data["events"][0] == {"t_s": None, "kind": "info", "text": "confirmed"}
    text = md.read_text()
    assert "## Ballast proposal (line)" in text and "| 1.50 | state | a/b |" in text
    assert "extra mass m_ext" in text and "10 kg at AftSB" in text
    assert "- ballast method: line" in text and data["method"] == "line"


def test_report_warns_of_an_infeasible_proposal(sabertooth: Profile, tmp_path: Path) -> None:
    W, r_g = payload_truth(sabertooth, 10.0, np.array(sabertooth.slot("AftSB").position_m))
    est = estimate_static(equilibrium_holds(sabertooth, W, r_g), sabertooth)
    lp = propose_ballast(est, sabertooth, method="lp")
    md, js = save_report(Report("sabertooth-dh2", "sim", "done", None, est,
                                dataclasses.replace(lp, feasible=True), None, []), tmp_path, "ok")
    assert json.loads(js.read_text())["warnings"] == [] and "Warning" not in md.read_text()
    bad = dataclasses.replace(lp, feasible=False, message="cannot level it.")
    md, js = save_report(Report("sabertooth-dh2", "sim", "done", None, est, bad, None, []),
                         tmp_path, "r")
    (warning,) = json.loads(js.read_text())["warnings"]
    assert warning == "the lp proposal is NOT FEASIBLE (best achievable): cannot level it."
    assert f"> **Warning**: {warning}" in md.read_text()


def test_result_panel_says_when_the_passive_trim_is_undefined(sabertooth: Profile) -> None:
    """A vehicle without static stability has no passive trim: no 'nan ± nan°'."""
    proposal = propose_ballast(with_net(sabertooth, *CASES["negative"]), sabertooth, "lp")
    assert not proposal.trim.stable
    text = "\n".join(line.plain for line in ResultPanel(sabertooth)._footer(proposal, 80))
    assert "passive trim undefined: no static stability" in text and "nan" not in text


def test_result_panel_shows_pieces_taken_out(bluerov: Profile) -> None:
    """Lead left aft on the nominal vehicle: the proposal takes it out, and says so."""
    installed = (InstalledPiece("W-aft-ctr", "lead-200g", 2),)
    lead = bluerov.piece("lead-200g")
    net_kg = 2 * (lead.mass_kg - bluerov.water_density_kg_m3 * lead.volume_m3)
    W, r_g = payload_truth(bluerov, net_kg, np.array(bluerov.slot("W-aft-ctr").position_m))
    est = estimate_static(equilibrium_holds(bluerov, W, r_g), bluerov)
    proposal = propose_ballast(est, bluerov, installed=installed)
    text = "\n".join(line.plain for line in ResultPanel(bluerov)._footer(proposal, 80))
    assert "W-aft-ctr -0.40 kg" in text and "−2×lead-200g" in text


@pytest.mark.asyncio
async def test_a_many_slot_proposal_keeps_the_top_view_at_80x24(bluerov: Profile) -> None:
    """The BlueROV2's 7-slot proposal in the result panel's 80×24 size (38×22 inside):
    the slots shrink to letters and loads, so the top view and the whole verdict fit."""
    from textual.app import App, ComposeResult

    W, r_g = payload_truth(bluerov, 0.5, np.array(bluerov.slot("W-aft-stbd").position_m))
    # equilibrium holds balance g(η) exactly: a vehicle that holds station, no drift
    est = estimate_static(equilibrium_holds(bluerov, W, r_g),
                          dataclasses.replace(bluerov, holds_station=True))
    proposal = propose_ballast(est, bluerov, method="milp", level_tol_deg=0.25)
    loaded = [s for s in proposal.slots if s.mass_kg or s.buoyancy_N]
    assert len(loaded) >= 5  # enough to push the top view out at full length
    panel = ResultPanel(bluerov)

    class One(App[None]):
        def compose(self) -> ComposeResult:
            yield panel

    async with One().run_test(size=(40, 24)) as pilot:
        panel.show_result(est, proposal)
        await pilot.pause()
        width, height = panel.content_size.width, panel.content_size.height
        assert len(panel._footer(proposal, width)) > height - 6 - 5  # full length too long
        lines = panel.render().plain.splitlines()
    assert len(lines) <= height
    assert any("╭" in line for line in lines)  # the top view's outline
    compact = "\n".join(lines)
    for s in loaded:
        assert f"+{s.weight_kg or s.float_kg:.2f}" in compact
    if not proposal.feasible:
        assert " ".join(lines).count("capacity") == " ".join(proposal.binding).count("capacity")
