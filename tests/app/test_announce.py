"""What the watch and the trim tell the pilot's ground station (``trimd/app/announce.py``):
the alert texts, their severities and length on the wire, and a trim's phases (INFO) and
verdict (NOTICE) from a whole session on an announcing link."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.app.test_session import run
from tests.helpers import PROFILES, FakeLink, FakeVehicle, payload_truth
from trimd.app.announce import RunAnnouncer, alert_text
from trimd.app.session import Session
from trimd.app.trim import TrimRequest, trim_session
from trimd.core.announce import Announcement, Severity, Text
from trimd.core.change import ChangeAlert
from trimd.core.events import Phase
from trimd.core.link import Announces
from trimd.core.profile import Profile
from trimd.drivers.mavlink.statustext import STATUSTEXT_BYTES, ascii_text


def _alert(component: int, total: float, std: float, age_s: float) -> ChangeAlert:
    return ChangeAlert(component, total, std, total, std, math.nan, 1000.0 - age_s, 1000.0, 3,
                       9.0, True)


@pytest.mark.parametrize(("alert", "severity", "text"), [
    (_alert(0, 2.43, 0.13, 300), Severity.ALERT,
     "TRIMD heavier 2.4±0.1N since 5min: water?"),
    (_alert(0, -1.2, 0.05, 40), Severity.CRITICAL,
     "TRIMD lighter 1.20±0.05N since 40s: lost weight?"),
    (_alert(1, 0.031, 0.005, 720), Severity.CRITICAL,
     "TRIMD nose-heavy 0.031±0.005Nm since 12min: weight fwd?"),
    (_alert(1, -0.2, 0.03, 9000), Severity.CRITICAL,
     "TRIMD tail-heavy 0.20±0.03Nm since 2.5h: weight aft?"),
    (_alert(2, 0.05, 0.01, 100), Severity.CRITICAL,
     "TRIMD stbd-heavy 0.05±0.01Nm since 2min: weight stbd?"),
    (_alert(2, -12.0, 2.5, 60), Severity.CRITICAL,
     "TRIMD port-heavy 12±2Nm since 60s: weight port?"),
])
def test_alert_texts(alert: ChangeAlert, severity: Severity, text: str) -> None:
    t = alert_text(alert)
    assert (t.severity, t.text) == (severity, text)
    assert t.urgent


def test_a_w_minus_b_alert_fits_one_statustext() -> None:
    """Water in (the alert that matters most) fits 50 bytes as sent, for any size below
    1000 N with a 1σ of 1 mN or more, at any age, so no ground station has to join
    chunks."""
    for total in (0.6, 2.43, 15.0, 99.9, 999.0):
        for std in (0.001, 0.13, 1.5):
            for age in (5, 89, 600, 5399, 100_000):
                wire = ascii_text(alert_text(_alert(0, total, std, age)).text)
                assert len(wire.encode()) <= STATUSTEXT_BYTES, wire


class AnnouncingLink(FakeLink):
    """A fake link that keeps what it is asked to announce."""

    def __init__(self, vehicle: FakeVehicle) -> None:
        super().__init__(vehicle)
        self.announced: list[Announcement] = []

    def announce(self, item: Announcement) -> None:
        self.announced.append(item)


def _link(profile: Profile) -> AnnouncingLink:
    W, r_g = payload_truth(profile, 10.0, np.array(profile.slot("AftSB").position_m))
    return AnnouncingLink(FakeVehicle(profile, W, r_g))


def test_a_trim_announces_its_phases_at_info_and_its_verdict_at_notice(
        sabertooth: Profile) -> None:
    link = _link(sabertooth)
    assert isinstance(link, Announces)
    request = TrimRequest(profile_ref=str(PROFILES / "sabertooth-dh2.yaml"), confirmed=True,
                          ballast_method="milp")
    session = trim_session(link, sabertooth, [], request)     # as trimd run builds it
    assert any(isinstance(p, RunAnnouncer) for p in session.presenters)
    result = run(session)
    assert result.phase is Phase.DONE, result.reason
    texts = [a for a in link.announced if isinstance(a, Text)]
    assert texts and all(t.text.startswith("TRIMD ") for t in texts)
    infos = [t.text for t in texts if t.severity == Severity.INFO]
    assert infos[0] == "TRIMD vehicle present (mode ALT_HOLD)", infos
    assert any(t.startswith("TRIMD hold 1/") for t in infos)
    assert any(t.endswith("steady: collecting") for t in infos)
    (verdict,) = [t.text for t in texts if t.severity == Severity.NOTICE]
    assert verdict.startswith("TRIMD trim done: W-B ") and " m_ext 10." in verdict, verdict
    assert texts[-1].severity == Severity.NOTICE


def test_an_aborted_trim_says_so_at_notice(sabertooth: Profile) -> None:
    link = _link(sabertooth)
    link.vehicle.stuck_at_deg = 5.0  # keeps the session running until the abort
    session = Session(link, sabertooth, recorder=None, presenters=[RunAnnouncer(link.announce)],
                      confirmed=True)
    result = run(session, after=0.5, then=session.abort)
    assert result.phase is Phase.ABORTED
    last = link.announced[-1]
    assert last == Text(Severity.NOTICE, "TRIMD trim aborted: aborted by the operator")
