"""In Debian's Chromium: a study that cannot run is never run.  A study whose build gave it no test question
shows why on its dashboard and stays closed when "Open study" is pressed; its participant link, even once
opened behind the dashboard's back, answers one clear page and writes nothing; a participant part of the way
through a study whose tests are gone meets that page, never a completion code; and a study whose robot is
not registered on this server answers the same page to participants and shows why to its researchers,
never a 500.  Screenshots: test-output/cannot_run_*.png."""
from __future__ import annotations

import pytest
from playwright.sync_api import expect

from studyapp.models import Answer, Participant, StepKind, Study
from tests.browser.grid_pages import OUT
from tests.conftest import complete_flow

pytestmark = [pytest.mark.browser]

ARRIVE = "?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X"


def _rows():
    return Participant.objects.count(), Answer.objects.count()


def test_a_failed_builds_study_cannot_be_opened_and_its_link_writes_nothing(make_study, live_server, staff_page,
                                                                            browser):
    page, errors = staff_page
    study = make_study(slug="failed-build", recruitment="prolific")
    Study.objects.filter(pk=study.pk).update(test_set=[], is_open=False)  # its build stopped at the test set
    page.goto(f"{live_server.url}/dashboard/{study.slug}/")
    expect(page.locator("main")).to_contain_text("Cannot open: It has no test questions")
    page.get_by_role("button", name="Open study").click()
    expect(page.locator("#study-status")).to_have_text("closed")
    expect(page.locator("[role=alert]").first).to_contain_text("It has no test questions")
    OUT.mkdir(exist_ok=True)
    page.screenshot(path=str(OUT / "cannot_run_dashboard.png"), full_page=True)
    Study.objects.filter(pk=study.pk).update(is_open=True)  # the admin, or a row from before the check
    before = _rows()
    participant = browser.new_context(viewport={"width": 390, "height": 844}).new_page()
    response = participant.goto(f"{live_server.url}/s/{study.slug}/" + ARRIVE.format(pid="5f0c0ffee0000000000000a1"))
    assert response.status == 503
    expect(participant.locator("h1")).to_have_text("This study is not available")
    participant.screenshot(path=str(OUT / "cannot_run_participant.png"), full_page=True)
    assert _rows() == before
    assert not errors, errors


def test_a_participant_whose_study_lost_its_tests_never_gets_a_code(make_study, live_server, browser):
    study = make_study(slug="lost-tests", recruitment="prolific", completion_code="PAID2026")
    page = browser.new_context(viewport={"width": 1280, "height": 800}).new_page()
    page.goto(f"{live_server.url}/s/{study.slug}/" + ARRIVE.format(pid="5f0c0ffee0000000000000b2"))
    p = complete_flow(Participant.objects.get(study=study), stop_before=StepKind.TEST)
    Study.objects.filter(pk=study.pk).update(test_set=[])
    before = _rows()
    response = page.goto(f"{live_server.url}{p.get_absolute_url()}")
    assert response.status == 503
    expect(page.locator("h1")).to_have_text("This study is not available")
    assert "PAID2026" not in page.content() and page.locator("#completion-code").count() == 0
    assert _rows() == before


def test_a_study_whose_robot_is_not_registered_answers_a_clear_page_never_500(make_study, live_server, staff_page,
                                                                              browser):
    page, errors = staff_page
    study = make_study(slug="unknown-robot", recruitment="prolific")
    Study.objects.filter(pk=study.pk).update(domain="vacuum", language="de")
    before = _rows()
    participant = browser.new_context().new_page()
    response = participant.goto(f"{live_server.url}/s/{study.slug}/" + ARRIVE.format(pid="5f0c0ffee0000000000000c3"))
    assert response.status == 503
    expect(participant.locator("h1")).to_have_text("Diese Studie ist nicht verfügbar")  # the study's language
    participant.screenshot(path=str(OUT / "cannot_run_unknown_robot.png"), full_page=True)
    assert _rows() == before
    response = page.goto(f"{live_server.url}/dashboard/{study.slug}/")
    assert response.status == 200
    expect(page.locator("main")).to_contain_text("Cannot open: Its robot 'vacuum' is not registered on this server")
    page.goto(f"{live_server.url}/dashboard/")
    expect(page.get_by_text("cannot run")).to_have_count(1)
    assert not errors, errors
