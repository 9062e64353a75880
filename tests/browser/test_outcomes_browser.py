"""In Debian's Chromium: a Prolific participant of a 20-minute study whose time runs out is told so on their
next click, shown the timed-out code and sent back to Prolific with it; the researcher's dashboard counts them
as timed out, marks another participant returned from a pasted id, and lists the study's codes.
Screenshots: test-output/ended_timed_out.png, test-output/dashboard_outcomes.png."""
from __future__ import annotations

from datetime import timedelta

import pytest
from django.utils import timezone
from playwright.sync_api import expect

from studyapp.models import Participant
from tests.browser.grid_pages import OUT

pytestmark = [pytest.mark.browser]


def test_time_runs_out_then_the_researcher_sees_it_and_marks_a_return(make_study, live_server, staff_page):
    page, errors = staff_page
    study = make_study(slug="timed", time_limit_minutes=20, estimated_minutes=12, recruitment="prolific",
                       completion_code="DONE2026", timed_out_code="TIME2026")
    page.goto(f"{live_server.url}/s/timed/?PROLIFIC_PID=slow000000000000000000001&STUDY_ID=S&SESSION_ID=X")
    expect(page.locator("dl")).to_contain_text("You have at most 20 minutes from now to finish.")
    page.click('button[value="yes"]')
    expect(page.locator("h1")).not_to_have_text("Consent to take part")
    Participant.objects.filter(study=study).update(started_at=timezone.now() - timedelta(minutes=21))
    page.reload()
    expect(page.locator("#ended")).to_have_text("Your time for this study is up")
    expect(page.locator("#completion-code")).to_have_text("TIME2026")
    expect(page.locator("#return-link")).to_have_attribute(
        "href", "https://app.prolific.com/submissions/complete?cc=TIME2026")
    OUT.mkdir(exist_ok=True)
    page.screenshot(path=str(OUT / "ended_timed_out.png"), full_page=True)

    Participant.objects.create(study=study, condition=study.conditions.first(), platform=Participant.PROLIFIC,
                               platform_pid="left000000000000000000001")
    page.goto(f"{live_server.url}/dashboard/timed/")
    expect(page.locator('tfoot [data-outcome="timed_out"]')).to_have_text("1")
    page.fill('#returned-form textarea[name="platform_ids"]', "left000000000000000000001")
    page.click('#returned-form button[type="submit"]')
    expect(page.locator(".notice")).to_contain_text("1 marked returned")
    expect(page.locator('tfoot [data-outcome="returned"]')).to_have_text("1")
    expect(page.locator("#outcome-codes")).to_contain_text("TIME2026")
    page.screenshot(path=str(OUT / "dashboard_outcomes.png"), full_page=True)
    assert set(Participant.objects.filter(study=study).values_list("outcome", flat=True)) == {"timed_out",
                                                                                              "returned"}
    assert not errors, errors
