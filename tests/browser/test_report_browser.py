"""The analysis report in a real browser (Debian's Chromium through Playwright, headless).

A synthetic study is simulated through the real models and flow, the researcher's live
analysis page is opened on pytest-django's live server, the figures must load and the tables
show numbers; a screenshot goes to test-output/analysis_report.png.  Then a new participant
finishes and the open page must pick the new numbers up by itself (the live refresh).

The page is reached through the project's URLconf (``dashboard_analysis``).
"""
from __future__ import annotations

from pathlib import Path

import pytest
from django.contrib.auth.models import User
from django.db import connections
from django.urls import reverse

from studyapp.analysis import views as analysis_views
from studyapp.analysis.simulate import run_participant, simulate
from studyapp.researcher.studies import make_study
from tests.conftest import PAPER_SEQUENCES, TINY_TEST_SET

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = pytest.mark.browser


@pytest.fixture
def staff_cookie(transactional_db, client):
    user = User.objects.create_user("researcher", password="pw-analysis-1", is_staff=True)
    client.force_login(user)
    return client.cookies["sessionid"].value


def test_report_renders_in_chromium_and_updates_live(staff_cookie, live_server, monkeypatch, tiny_table,
                                                     browser):  # db first

    study = make_study(tiny_table, "browser", PAPER_SEQUENCES, **TINY_TEST_SET)
    rng = simulate(study, n_per_condition=5, seed=4)
    monkeypatch.setattr(analysis_views, "REFRESH_SECONDS", 1)
    OUT.mkdir(exist_ok=True)
    shot = OUT / "analysis_report.png"
    if shot.exists():
        shot.unlink()
    url = live_server.url + reverse("dashboard_analysis", args=["browser"])
    host = live_server.url.split("//")[1].split(":")[0]

    try:
        ctx = browser.new_context(viewport={"width": 1280, "height": 900})
        ctx.add_cookies([{"name": "sessionid", "value": staff_cookie, "domain": host, "path": "/"}])
        page = ctx.new_page()
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        resp = page.goto(url)
        assert resp.status == 200
        page.wait_for_selector("#analysis-report")
        # figures loaded (decoded PNGs with real size)
        for fig in ("#fig-scores img", "#fig-correlations img", "#fig-examples img"):
            size = page.eval_on_selector(fig, "img => [img.complete, img.naturalWidth, img.naturalHeight]")
            assert size[0] and size[1] > 300 and size[2] > 150, (fig, size)
        # tables with numbers
        assert page.locator("#anova-1 table.anova-type2 tbody tr").count() == 3  # distance, determinism, resid
        assert page.locator("#anova-2 table.anova-type3 tbody tr").count() == 4
        welch = page.inner_text("#table-welch")
        assert "coverage-approx* vs random" in welch and "approx* (det-euclidean) vs exact" in welch
        first_n = page.inner_text(".summary-line")
        assert "45" in first_n  # 5 x 9 participants
        assert page.locator("#table-correlations tbody tr").count() == 4
        page.screenshot(path=str(shot), full_page=True)

        # a new participant finishes: the open page refreshes itself.  The poll's answer waits for the
        # report to be recomputed (1.4 s on an idle machine, over 15 s once beside a busy loop, in the
        # live server's thread of this process, beside the model panel's fit): a hang guard only
        run_participant(study, rng)
        page.wait_for_function(  # null-safe: a check in the moment the report is replaced must not throw
            "() => document.querySelector('.summary-line')?.innerText.includes('46')", timeout=180_000)
        assert errors == []
    finally:
        connections.close_all()  # the ORM call above ran in Playwright's context: close its connection
    assert shot.exists() and shot.stat().st_size > 50_000
