"""``trimd ballast apply`` records the installed ballast; proposals then start from it
(``trimd ballast``, ``trimd run``); a profile may declare ballast installed."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from tests.ballast.test_ballast import Payload, estimate_for
from tests.helpers import PROFILES
from trimd.app.history import History
from trimd.cli.main import main
from trimd.core.estimate_json import estimate_to_dict
from trimd.core.profile import InstalledPiece, Profile

LEAD = "lead-200g"


@pytest.fixture
def est_file(tmp_path: Path, bluerov: Profile) -> Path:
    """A perfect estimate of a BlueROV2 carrying a float at the nose and 2 lead aft."""
    lead = bluerov.piece(LEAD)
    payload = [Payload(0.0, 0.5, (0.15, 0.0, 0.0)),
               Payload(2 * lead.mass_kg, 2 * bluerov.water_density_kg_m3 * lead.volume_m3,
                       bluerov.slot("W-aft-ctr").position_m)]
    path = tmp_path / "est.json"
    path.write_text(json.dumps(estimate_to_dict(estimate_for(bluerov, payload))))
    return path


def _json(capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    out: dict[str, object] = json.loads(capsys.readouterr().out)
    return out


def test_apply_records_the_proposal_and_the_next_proposal_starts_from_it(
        tmp_path: Path, est_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = ["--db", str(tmp_path / "h.db"), "--vehicle", "rov"]
    assert main(["ballast", "apply", "--profile", "bluerov2-heavy", "--set",
                 f"W-aft-ctr:{LEAD}=2", *db]) == 0
    assert "add 2 × lead-200g to W-aft-ctr" in capsys.readouterr().out
    assert main(["ballast", "--profile", "bluerov2-heavy", "--estimate", str(est_file),
                 "--json", *db]) == 0
    proposal = _json(capsys)
    assert proposal["installed_before"] == [{"slot": "W-aft-ctr", "piece": LEAD, "count": 2}]
    assert any(c["action"] == "move" for c in proposal["changes"])  # type: ignore[attr-defined]
    assert main(["ballast", "apply", "--profile", "bluerov2-heavy", "--estimate",
                 str(est_file), "--json", *db]) == 0
    applied = _json(capsys)
    assert applied["source"] == "proposal"
    assert applied["installed"] == proposal["installed_after"]
    assert applied["changes"] == [c["text"] for c in proposal["changes"]]  # type: ignore[attr-defined]
    predicted = applied["predicted"]
    assert isinstance(predicted, dict)
    assert predicted["roll_deg"] == pytest.approx(proposal["predicted_roll_deg"], abs=1e-9)
    with History(tmp_path / "h.db") as h:
        records = h.installs("rov")
    assert [r.source for r in records] == ["edited", "proposal"]
    assert [{"slot": x.slot, "piece": x.piece, "count": x.count}
            for x in records[-1].pieces] == proposal["installed_after"]


def test_apply_with_edited_counts(tmp_path: Path, est_file: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    db = ["--db", str(tmp_path / "h.db")]
    assert main(["ballast", "apply", "--profile", "bluerov2-heavy", "--estimate",
                 str(est_file), "--set", f"w-front-ctr:{LEAD}=1", "--json", *db]) == 0
    applied = _json(capsys)
    assert applied["source"] == "edited"
    assert {"slot": "W-front-ctr", "piece": LEAD, "count": 1} in applied["installed"]  # type: ignore[operator]
    with History(tmp_path / "h.db") as h:
        latest = h.installed("bluerov2-heavy")
    assert latest is not None and InstalledPiece("W-front-ctr", LEAD, 1) in latest.pieces


@pytest.mark.parametrize(("args", "message"), [
    (["--set", "W-aft-ctrr:lead-200g=1"], "did you mean 'W-aft-ctr'"),
    (["--set", "W-aft-ctr:lead-200g"], "expected SLOT:PIECE=COUNT"),
    (["--set", "W-aft-ctr:lead-200g=4"], "takes 0.6 kg of weight; 0.8 kg installed"),
    (["--set", "F-aft-port:lead-200g=1"], "F-aft-port takes 0 kg of weight"),
    ([], "give --estimate"),
])
def test_apply_user_errors(tmp_path: Path, args: list[str], message: str,
                           capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "h.db"
    assert main(["ballast", "apply", "--profile", "bluerov2-heavy", "--db", str(db),
                 *args]) == 2
    assert message in capsys.readouterr().err
    assert not db.exists() or History(db).installs("bluerov2-heavy") == []


def test_ballast_without_profile_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ballast"]) == 2
    assert "--profile, --estimate" in capsys.readouterr().err


def test_a_profile_declares_installed_ballast(tmp_path: Path, est_file: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    data = yaml.safe_load((PROFILES / "bluerov2-heavy.yaml").read_text())
    data["ballast"]["installed"] = [{"slot": "W-aft-ctr", "piece": LEAD, "count": 2}]
    profile = tmp_path / "rov.yaml"
    profile.write_text(yaml.safe_dump(data))
    assert main(["ballast", "--profile", str(profile), "--estimate", str(est_file),
                 "--json", "--db", str(tmp_path / "none.db")]) == 0
    proposal = _json(capsys)
    assert proposal["installed_before"] == [{"slot": "W-aft-ctr", "piece": LEAD, "count": 2}]
    assert not (tmp_path / "none.db").exists()
    assert main(["ballast", "--profile", "bluerov2-heavy", "--estimate", str(est_file),
                 "--json", "--db", str(tmp_path / "none.db")]) == 0  # shipped: adding only
    add_only = _json(capsys)
    assert add_only["installed_before"] == []
    assert proposal["feasible"] and proposal["pieces_handled"] < add_only["pieces_handled"]


def test_run_proposes_from_the_ballast_the_history_holds(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = ["--db", str(tmp_path / "h.db")]
    assert main(["ballast", "apply", "--profile", "bluerov2-heavy", "--set",
                 f"W-aft-ctr:{LEAD}=2", *db]) == 0
    assert main(["run", "--link", "sim:payload=0.363844@W-aft-ctr,seed=5", "--profile",
                 "bluerov2-heavy", "--headless", "--yes", "--no-record", *db]) == 0
    out = capsys.readouterr().out
    assert "installed before  2 × lead-200g in W-aft-ctr" in out
    with History(tmp_path / "h.db") as h:
        [trim] = h.trims("bluerov2-heavy")
    assert trim.proposal is not None and trim.proposal["feasible"]
    assert trim.proposal["installed_before"] == [{"slot": "W-aft-ctr", "piece": LEAD,
                                                  "count": 2}]


def test_a_proposal_from_other_ballast_is_refused(tmp_path: Path, est_file: Path,
                                                  bluerov: Profile) -> None:
    """The TUI's apply records a proposal made at the end of the trim; when ballast was
    recorded for the vehicle since, that proposal no longer starts from what is on it:
    refused, nothing written (the history keeps exactly its one record)."""
    from trimd.app.apply import apply_ballast
    from trimd.app.files import read_estimate
    from trimd.ballast.propose import propose_ballast
    from trimd.core.errors import DataError

    db = tmp_path / "h.db"
    estimate = read_estimate(est_file)
    proposal = propose_ballast(estimate, bluerov, "milp")  # from nothing installed
    with History(db) as h:
        h.record_installed("rov", bluerov.name, 1.0, "edited",
                           [InstalledPiece("W-aft-ctr", LEAD, 2)])
    with pytest.raises(DataError, match="starts from ballast other than"):
        apply_ballast(db, "rov", bluerov, estimate=estimate, proposal=proposal)
    with History(db) as h:
        assert len(h.installs("rov")) == 1
    applied = apply_ballast(db, "other-rov", bluerov, estimate=estimate, proposal=proposal)
    assert applied.installed == proposal.installed_after and applied.source == "proposal"
    assert applied.trim is not None and applied.trim.stable
