"""What a participant sees (issue 22, item 8): training waits for Play when the participant's system
asks for reduced motion, and a training example that repeats an earlier one says it does so on
purpose.  Debian's Chromium through Playwright, against the live test server."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from playwright.sync_api import expect, sync_playwright

from studyapp import flow
from studyapp.assignment import assign
from tests.conftest import complete_flow

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def repeating(transactional_db, make_study):
    """A participant on the first training example of a condition that shows environment 500 twice
    in a row (as prob-reward's sequences do), then 5780."""
    study = make_study("repeat", sequences={"again": [500, 500, 5780]})
    p = assign(study, "prolific", "repeat-1", platform_study_id="S", platform_session_id="X")
    p = complete_flow(p, stop_before="training")
    assert flow.current_step(p).kind == "training"
    return p


def next_button(page):
    return page.locator("form[data-require-played] button[type=submit]")


@pytest.mark.parametrize("motion", ["reduce", "no-preference"])
def test_training_autoplays_only_without_reduced_motion_and_repeats_are_announced(repeating, live_server, motion):
    url = f"{live_server.url}{repeating.get_absolute_url()}"
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True)
        page = browser.new_page(viewport={"width": 1280, "height": 900}, reduced_motion=motion)
        errors = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.clock.install()
        page.goto(url)
        page.wait_for_selector("body[data-ready]", state="attached")
        expect(page.locator("h1")).to_have_text("Example 1 of 3")
        expect(page.locator(".repeat")).to_have_count(0)  # the first showing is no repeat
        page.clock.run_for(8000)  # longer than any drive
        if motion == "reduce":  # nothing moved: still at t = 0, waiting for Play
            expect(next_button(page)).to_be_disabled()
            assert page.evaluate("document.querySelector('canvas').scene.t") == 0
            expect(page.locator(".hint")).to_contain_text("Press Play")
            page.locator("[data-action=play]").click()
            page.clock.run_for(8000)
        expect(next_button(page)).to_be_enabled()
        next_button(page).click()
        expect(page.locator("h1")).to_have_text("Example 2 of 3")
        notice = page.locator(".repeat")
        expect(notice).to_contain_text("You have seen this situation before (example 1)")
        expect(notice).to_contain_text("on purpose")
        if motion == "reduce":
            OUT.mkdir(exist_ok=True)
            page.screenshot(path=str(OUT / "training_repeat_reduced_motion.png"))
        page.clock.run_for(8000)
        if motion == "reduce":
            expect(next_button(page)).to_be_disabled()
            page.locator("[data-action=play]").click()
            page.clock.run_for(8000)
        next_button(page).click()
        expect(page.locator("h1")).to_have_text("Example 3 of 3")
        expect(page.locator(".repeat")).to_have_count(0)  # another environment: no notice
        browser.close()
    assert not errors, errors
