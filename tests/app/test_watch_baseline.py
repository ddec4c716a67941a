"""``trimd watch --baseline last`` after ``ballast apply`` and a verify hold: the baseline is
the verify hold's measurement of the ballasted vehicle (the newest of trim and verify for
the vehicle), and the watch says which it used."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.helpers import equilibrium_holds
from trimd.app.history import History
from trimd.app.history.baseline import latest_baseline
from trimd.cli.main import main
from trimd.core.errors import DataError
from trimd.core.estimate import estimate_static
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.profile import InstalledPiece, Profile
from trimd.drivers.sim.payload import mass_properties

VERIFY = {"as_predicted": True, "measured_N_Nm": [1.5, -0.2, 0.1],
          "measured_std_N_Nm": [0.3, 0.05, 0.04]}


def _trim(history: History, profile: Profile, t: float) -> np.ndarray:
    m = mass_properties(profile)
    est = estimate_static(equilibrium_holds(profile, m.W, m.r_g), profile)
    history.record_trim("rov", profile.name, t, estimate_to_dict(est))
    return est.q


def test_the_newest_measurement_is_the_baseline(tmp_path: Path, bluerov: Profile) -> None:
    with History(tmp_path / "h.db") as h:
        with pytest.raises(DataError, match="no trim or verify hold of vehicle rov"):
            latest_baseline(h, "rov")
        q_trim = _trim(h, bluerov, 100.0)
        latest = latest_baseline(h, "rov")
        assert latest.kind == "trim" and np.allclose(latest.baseline.q, q_trim)
        assert latest.baseline.source.startswith("the last trim of rov at 1970-01-01")

        h.record_installed("rov", bluerov.name, 200.0, "proposal",
                           [InstalledPiece("W-aft-ctr", "lead-200g", 1)])
        latest = latest_baseline(h, "rov")  # ballast on since the trim: said so
        assert latest.kind == "trim" and "after the last trim of rov" in latest.warning
        h.record_verify("rov", 250.0, {"as_predicted": True})  # older trimd: no measurement
        assert latest_baseline(h, "rov").kind == "trim"

        h.record_verify("rov", 300.0, VERIFY)
        latest = latest_baseline(h, "rov")
        assert latest.kind == "verify" and latest.warning == ""
        b = latest.baseline
        assert np.allclose(b.q[:3], VERIFY["measured_N_Nm"]) and np.isnan(b.q[3])
        assert np.allclose(b.var[:3], np.square(VERIFY["measured_std_N_Nm"]))
        assert b.var[3] == np.inf and "the verify hold of rov" in b.source

        q_trim = _trim(h, bluerov, 400.0)  # trimmed again since: the trim
        latest = latest_baseline(h, "rov")
        assert latest.kind == "trim" and np.allclose(latest.baseline.q, q_trim)


def test_watch_says_which_baseline_it_used(tmp_path: Path, bluerov: Profile,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "h.db"
    with History(db) as h:
        _trim(h, bluerov, 100.0)
        h.record_installed("rov", bluerov.name, 200.0, "proposal",
                           [InstalledPiece("W-aft-ctr", "lead-200g", 1)])
        h.record_verify("rov", 300.0, VERIFY)
    watch = ["watch", "--link", "sim:seed=1", "--profile", "bluerov2-heavy", "--json",
             "--duration", "5", "--no-history", "--baseline", "last"]
    main([*watch, "--db", str(db), "--vehicle", "rov"])
    err = capsys.readouterr().err
    assert "trimd watch: baseline: the verify hold of rov at 1970-01-01 00:05:00 UTC" in err
    assert "warning" not in err
    assert main([*watch, "--db", str(tmp_path / "empty.db")]) == 2
    assert "no trim or verify hold of vehicle bluerov2-heavy" in capsys.readouterr().err


@pytest.mark.slow
def test_after_apply_and_verify_the_ballast_is_no_change(
        tmp_path: Path, sabertooth: Profile, capsys: pytest.CaptureFixture[str]) -> None:
    """Simulated Sabertooth, 10 kg at AftSB: trim, ``ballast apply``, the ballast fitted,
    verify hold; then a dive with that ballast. Against the trim as measured (before the
    ballast) the watch alerts on the ballast itself; with ``--baseline last`` (the verify
    hold) it does not."""
    import json

    from tests.helpers import carried
    from trimd.app.files import read_installed

    common = ["--profile", "sabertooth-dh2", "--db", str(tmp_path / "h.db"), "--vehicle",
              "rov"]
    run = ["run", *common, "--headless", "--yes", "--json", "--no-record"]
    assert main([*run, "--link", "sim:payload=10@AftSB"]) == 0
    trim = tmp_path / "trim.jsonl"
    trim.write_text(capsys.readouterr().out)
    assert main(["ballast", "apply", *common, "--estimate", str(trim)]) == 0
    extra = carried(read_installed(trim, sabertooth), sabertooth.gravity_m_s2)
    link = f"sim:payload=10@AftSB+{extra}"
    assert main([*run, "--link", f"{link},seed=3", "--verify"]) == 0
    capsys.readouterr()
    estimate = tmp_path / "est.json"
    estimate.write_text(json.dumps(json.loads(trim.read_text().splitlines()[-1])["estimate"]))
    watch = ["watch", *common, "--link", f"{link},pilot=dive,seed=4", "--json",
             "--duration", "300", "--no-history"]

    assert main([*watch, "--baseline", str(estimate)]) == 0
    alerts = [x for x in map(json.loads, capsys.readouterr().out.splitlines())
              if x["type"] == "alert"]
    assert {a["quantity"] for a in alerts} >= {"net_force_N"}  # the floats added: lighter
    assert main([*watch, "--baseline", "last"]) == 0
    out, err = capsys.readouterr()
    assert "baseline: the verify hold of rov" in err
    assert [x for x in map(json.loads, out.splitlines()) if x["type"] == "alert"] == []
