"""In Debian's Chromium: a desktop-only study (screens at least 1024 px wide, no phones, no tablets) turns a
390 × 844 phone away on its consent page with the reason, keeps no place for it and counts the refusal;
a laptop takes part.  Screenshot: test-output/device_refused_phone.png."""
from __future__ import annotations

import pytest
from playwright.sync_api import expect

from studyapp.models import Participant, Study
from tests.browser.grid_pages import OUT

pytestmark = [pytest.mark.browser]

IPHONE = "Mozilla/5.0 (iPhone; CPU iPhone OS 17_0 like Mac OS X) AppleWebKit/605.1.15 Mobile/15E148 Safari/604.1"


def test_a_phone_is_turned_away_from_a_desktop_only_study_and_a_laptop_takes_part(transactional_db, live_server,
                                                                                  make_study, browser):
    study = make_study(slug="desk", min_screen_width=1024, allow_phones=False, allow_tablets=False,
                       recruitment="prolific")
    errors = []
    phone = browser.new_context(viewport={"width": 390, "height": 844}, has_touch=True, is_mobile=True,
                                user_agent=IPHONE).new_page()
    phone.on("pageerror", lambda exc: errors.append(str(exc)))
    phone.goto(f"{live_server.url}/s/desk/?PROLIFIC_PID=phone0000000000000000001&STUDY_ID=S&SESSION_ID=X")
    problem = phone.locator("[data-device-problem]")
    expect(problem).to_be_visible()
    expect(problem).to_contain_text("This study cannot be done on a phone")
    expect(phone.locator('button[value="yes"]')).to_be_hidden()
    phone.click("[data-device-leave]")
    expect(phone.locator("#device-refused")).to_contain_text("no place was kept for you")
    OUT.mkdir(exist_ok=True)
    phone.screenshot(path=str(OUT / "device_refused_phone.png"), full_page=True)
    assert not Participant.objects.filter(study=study).exists()
    assert Study.objects.get(pk=study.pk).device_refusals == 1

    laptop = browser.new_context(viewport={"width": 1280, "height": 900}).new_page()
    laptop.on("pageerror", lambda exc: errors.append(str(exc)))
    laptop.goto(f"{live_server.url}/s/desk/?PROLIFIC_PID=laptop000000000000000001&STUDY_ID=S&SESSION_ID=X")
    expect(laptop.locator("[data-device-problem]")).to_be_hidden()
    laptop.click('button[value="yes"]')
    expect(laptop.locator("h1")).not_to_have_text("Consent to take part")
    p = Participant.objects.get(study=study)
    assert p.position == 1 and Study.objects.get(pk=study.pk).device_refusals == 1
    assert not errors, errors
