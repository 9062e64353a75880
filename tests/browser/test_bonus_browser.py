"""In Debian's Chromium: a Prolific participant of a study that pays a performance bonus finishes on the
demographics page and reads their bonus, with their code, on the completion page; a reload shows the same.
Screenshot: test-output/done_with_bonus.png."""
from __future__ import annotations

from decimal import Decimal

import pytest
from playwright.sync_api import expect

from studyapp import flow
from studyapp.models import Participant, StepKind
from tests.browser.grid_pages import OUT
from tests.conftest import complete_flow

pytestmark = [pytest.mark.browser]


def test_the_completion_page_shows_the_bonus_earned(make_study, live_server, staff_page):
    page, errors = staff_page
    study = make_study(slug="bonus", recruitment="prolific", completion_code="DONE2026", bonus_per_correct=0.25,
                       bonus_cap=1.0)
    page.goto(f"{live_server.url}/s/bonus/?PROLIFIC_PID=bonus00000000000000000001&STUDY_ID=S&SESSION_ID=X")
    p = complete_flow(Participant.objects.get(study=study), stop_before=StepKind.DEMOGRAPHICS)
    assert flow.current_step(p).kind == StepKind.DEMOGRAPHICS
    page.reload()
    page.fill("#age", "41")
    page.check('input[name="gender"] >> nth=0')
    page.click("button.primary")
    n_tests = len(study.test_set)
    earned = min(Decimal("0.25") * n_tests, Decimal("1.00"))
    expect(page.locator("#bonus")).to_contain_text(f"£{earned:.2f}")
    expect(page.locator("#completion-code")).to_have_text("DONE2026")
    OUT.mkdir(exist_ok=True)
    page.screenshot(path=str(OUT / "done_with_bonus.png"), full_page=True)
    page.goto(f"{live_server.url}/s/bonus/p/{p.token}/")
    expect(page.locator("#bonus")).to_contain_text(f"£{earned:.2f}")
    assert Participant.objects.get(pk=p.pk).bonus == earned
    assert not errors, errors
