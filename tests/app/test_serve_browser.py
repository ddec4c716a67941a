"""``trimd serve``'s page in a real browser (playwright driving Debian's ``chromium``, else
playwright's own): during a leaky simulated dive the page shows the alert, the plot of the
dive's segments with the baseline band, and says that trims are started topside. Skips,
saying why, where neither playwright nor a chromium can be found (``make browser`` installs
them)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tests.app.serve_process import HANG_GUARD_S, Serve

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed "
                               "(pip install playwright; make browser)")


def _launch(p: sync_api.Playwright) -> sync_api.Browser:
    system = shutil.which("chromium") or shutil.which("chromium-browser")
    try:
        return p.chromium.launch(executable_path=system) if system else p.chromium.launch()
    except sync_api.Error as exc:
        pytest.skip(f"no chromium to drive (apt-get install chromium, or playwright install "
                    f"chromium): {str(exc).splitlines()[0]}")


@pytest.mark.slow
def test_the_page_shows_the_alert_and_the_plot(tmp_path: Path) -> None:
    serve = Serve.sim(tmp_path)
    try:
        serve.wait_for("/api/status", lambda s: True)
        with sync_api.sync_playwright() as p:
            browser = _launch(p)
            page = browser.new_page()
            page.goto(f"http://127.0.0.1:{serve.port}/")
            guard = HANG_GUARD_S * 1000
            page.wait_for_selector("#alerts li.alert", timeout=guard)
            assert "heavier by" in page.inner_text("#alerts")
            page.wait_for_selector("svg[data-title^='W − B'] rect.band", timeout=guard)
            assert page.locator("svg[data-title^='W − B'] circle").count() >= 3
            assert page.locator("svg[data-title^='W − B'] line.alertline").count() >= 1
            assert "trimd run" in page.inner_text(".note")
            assert "ALT_HOLD" in page.inner_text("#status")
            browser.close()
    finally:
        assert serve.stop() == 0, serve.output()
