"""Condition names in Chromium: the analysis page answers a bad ``?compare=`` with its message
(and no live report polling behind it), and a study stored with two names of one condition says on
its dashboard and its analysis page why it cannot open or be analysed.  Screenshots go to
test-output/compare_error.png and test-output/aliased_study.png."""
from __future__ import annotations

from pathlib import Path

import pytest
from django.contrib.auth.models import User

from studyapp.models import Condition

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = pytest.mark.browser


def test_compare_errors_and_an_aliased_study_in_chromium(transactional_db, client, live_server, make_study,
                                                          browser):
    make_study("fam", sequences={"exact": [500], "det-euclidean": [5780], "random": [7107]})
    old = make_study("old", sequences={"det-strategy": [500, 5780, 12165], "exact": [7107, 15245]})
    Condition.objects.filter(study=old, name="exact").update(name="prob-strategy")  # stored before the check
    client.force_login(User.objects.create_user("r", password="pw-names-1", is_staff=True))
    host = live_server.url.split("//")[1].split(":")[0]
    OUT.mkdir(exist_ok=True)
    ctx = browser.new_context(viewport={"width": 1280, "height": 700})
    ctx.add_cookies([{"name": "sessionid", "value": client.cookies["sessionid"].value, "domain": host,
                      "path": "/"}])
    page = ctx.new_page()
    resp = page.goto(live_server.url + "/dashboard/fam/analysis/?compare=exact:exact&compare=foo:random")
    alert = page.locator('[role="alert"]')
    assert resp.status == 400 and "compares exact with itself" in alert.inner_text()
    assert page.locator("#analysis-live").count() == 0
    page.screenshot(path=str(OUT / "compare_error.png"), full_page=True)
    page.get_by_text("The analysis without these comparisons").click()
    page.wait_for_selector("#analysis-live")

    page.goto(live_server.url + "/dashboard/old/")
    text = page.locator("body").inner_text()
    assert "Cannot open: conditions 'det-strategy' and 'prob-strategy' are one condition" in text
    page.screenshot(path=str(OUT / "aliased_study.png"), full_page=True)
    page.goto(live_server.url + "/dashboard/old/analysis/")
    assert "This study cannot be analysed" in page.locator('[role="alert"]').inner_text()
