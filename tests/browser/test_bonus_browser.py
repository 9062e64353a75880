"""In Debian's Chromium: a Prolific participant of a study that pays a performance bonus finishes on the
demographics page and reads their bonus, with their code, on the completion page; a reload shows the same.
The consent page states the rule before anyone agrees, in English and in German.  Screenshots:
test-output/done_with_bonus.png, consent_with_bonus_en.png, consent_with_bonus_de.png."""
from __future__ import annotations

from decimal import Decimal

import pytest
from playwright.sync_api import expect

from studyapp.models import Participant, StepKind
from studyapp.participant import flow
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


@pytest.mark.parametrize("language, how, paid, says", [
    ("en", "paid through Prolific", "£2.50 (paid through Prolific)",
     "£0.25 for each test question you answer correctly, at most £1.00 in all, on top of the payment."),
    ("de", "über Prolific", "2,50\u00a0£ (über Prolific)",
     "0,25\u00a0£ für jede Testfrage, die Sie richtig beantworten, insgesamt höchstens 1,00\u00a0£, "
     "zusätzlich zur Bezahlung."),
])
def test_the_consent_page_states_the_bonus_rule(make_study, live_server, browser, language, how, paid, says):
    """Every amount on the page written one way, the language's (bonuses.participant_label)."""
    make_study(slug=f"bonus-{language}", recruitment="prolific", completion_code="DONE2026", bonus_per_correct=0.25,
               bonus_cap=1.0, language=language, payment=how, payment_amount=2.5, estimated_minutes=12)
    page = browser.new_context(viewport={"width": 1280, "height": 800}).new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(f"{live_server.url}/s/bonus-{language}/?PROLIFIC_PID=bonus0000000000000000000{language}"
              "&STUDY_ID=S&SESSION_ID=X")
    expect(page.locator("[data-bonus-rule]")).to_have_text(says)
    expect(page.locator("[data-payment]")).to_have_text(paid)
    OUT.mkdir(exist_ok=True)
    page.screenshot(path=str(OUT / f"consent_with_bonus_{language}.png"), full_page=True)
    assert not errors, errors
