"""A participant with a Prolific id goes through the whole study in Debian's Chromium (headless).

pytest-django's live_server serves the app; Playwright drives /usr/bin/chromium.
Animations run on Playwright's fake clock (page.clock), so "play every option"
takes milliseconds of wall time while the page's requestAnimationFrame loop
still runs through every frame.  Along the way: keyboard-only answering,
a reload mid-test that resumes exactly, the back button not re-opening a
stored question, phone width without horizontal scrolling, and screenshots
of the training and test pages in test-output/.  At the end the stored
answers and the redirect to Prolific's completion URL are checked.
"""
from __future__ import annotations

from pathlib import Path

import pytest
from django.db import connections
from playwright.sync_api import expect

from studyapp.models import Answer, Participant
from studyapp.participant import flow
from studyapp.researcher.studies import build_study, demo_spec

OUT = Path(__file__).resolve().parents[2] / "test-output"
PID, STUDY_ID, SESSION_ID = "5f0c0ffee0000000000000ab", "st-1", "se-1"

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def demo_study(transactional_db, demo_table, monkeypatch):
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))  # the demo exactly as `make demo` serves it
    return build_study(demo_spec())


def ready(page):
    """Wait until the page's module script has wired the controls."""
    page.wait_for_selector("body[data-ready]", state="attached")


def open_on_fake_clock(browser, url: str, **page_options):
    """A new page of `browser` at `url` (`page_options`: Playwright's new_page options) on Playwright's fake
    clock, once its controls are wired, and the list of JavaScript errors it meets: (page, errors)."""
    page = browser.new_page(**page_options)
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.clock.install()
    page.goto(url)
    ready(page)
    return page, errors


def play_all(page, ms=5600):
    """Let every started animation run to its end on the fake clock."""
    page.clock.run_for(ms)


def h1(page) -> str:
    return page.locator("h1").inner_text()


def tab_to(page, selector, limit=40):
    """Press Tab until the focused element matches `selector` (what a keyboard user does)."""
    for _ in range(limit):
        if page.evaluate("(sel) => document.activeElement && document.activeElement.matches(sel)", selector):
            return
        page.keyboard.press("Tab")
    raise AssertionError(f"{selector} cannot be reached with Tab")


def answer_test_by_keyboard(page, choose_label="A", rating=5):
    """Play every option, choose one, rate all: keys only (Space on buttons and radios, arrows in groups)."""
    ready(page)
    for button in page.locator('[data-action="play"]').all():
        button.focus()
        page.keyboard.press("Space")
    play_all(page)
    choice = page.locator(f'input[name="choice"][value="{choose_label}"]')
    choice.focus()
    page.keyboard.press("Space")
    for group in page.locator(".rating").all():
        group.locator("input").first.focus()
        page.keyboard.press("Space")
        for _ in range(rating - 1):
            page.keyboard.press("ArrowRight")
    submit = page.locator('#test-form button[type="submit"]')
    assert submit.is_enabled()
    submit.focus()
    page.keyboard.press("Enter")


def test_participant_flow_in_chromium(demo_study, live_server, browser):  # db first: last torn down
    OUT.mkdir(exist_ok=True)
    entry = f"{live_server.url}/s/{demo_study.slug}/?PROLIFIC_PID={PID}&STUDY_ID={STUDY_ID}&SESSION_ID={SESSION_ID}"
    context = browser.new_context(viewport={"width": 1200, "height": 1000})
    page = context.new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    # the participant pages' Content-Security-Policy must not block anything they need
    page.on("console", lambda msg: errors.append(msg.text) if "Content Security Policy" in msg.text else None)
    completed = []
    page.route("https://app.prolific.com/**", lambda route: (completed.append(route.request.url), route.fulfill(
        status=200, content_type="text/html", body="<h1>Prolific: submission complete</h1>"))[-1])
    page.clock.install()

    # consent and instructions, keyboard only
    page.goto(entry)
    expect(page.locator("h1")).to_have_text("Consent to take part")
    tab_to(page, 'button[value="yes"]')
    page.keyboard.press("Enter")
    expect(page.locator("h1")).to_have_text("Instructions")
    tab_to(page, "button.primary")
    page.keyboard.press("Enter")

    p = Participant.objects.get(platform_pid=PID)
    assert (p.platform, p.platform_study_id, p.platform_session_id) == ("prolific", STUDY_ID, SESSION_ID)
    n_train = len(p.condition.training)

    # training: each example autoplays; "next" unlocks only at the end of the animation
    for i in range(n_train):
        expect(page.locator("h1")).to_have_text(f"Example {i + 1} of {n_train}")
        submit = page.locator('form[data-require-played] button[type="submit"]')
        ready(page)
        expect(page.locator(".scene")).to_have_attribute("data-state", "playing")  # it autoplays
        page.clock.run_for(2500)
        assert submit.is_disabled()
        if i == 0:
            page.screenshot(path=str(OUT / "training.png"))
        play_all(page, 3200)
        expect(submit).to_be_enabled()
        if i == 0:
            page.locator('[data-action="trail"]').click()
            expect(page.locator('[data-action="trail"]')).to_have_attribute("aria-pressed", "true")
            page.screenshot(path=str(OUT / "training_trail.png"))
            page.locator('[data-action="play"]').click()  # replay works after the trail
            play_all(page)
        if i == 1:  # reloading a watched example keeps it watched
            page.reload()
            ready(page)
            expect(page.locator("h1")).to_have_text(f"Example 2 of {n_train}")
            expect(submit).to_be_enabled()
        submit.click()

    # test 1 by keyboard alone
    expect(page.locator("h1")).to_have_text("Question 1 of 6")
    assert page.locator('#test-form button[type="submit"]').is_disabled()
    for selector in ('[data-action="play"]', '[data-action="trail"]', 'input[name="choice"]',
                     'input[name^="rating_"]'):
        tab_to(page, selector)  # every kind of control is in the tab order
    page.screenshot(path=str(OUT / "test.png"), full_page=True)
    answer_test_by_keyboard(page, choose_label="A", rating=6)

    # the back button shows the current step, never the stored question
    expect(page.locator("h1")).to_have_text("Question 2 of 6")
    page.go_back()
    expect(page.locator("h1")).to_have_text("Question 2 of 6")

    # test 2, then test 3 half done and the page reloaded: it resumes at test 3
    answer_test_by_keyboard(page, choose_label="B", rating=4)
    expect(page.locator("h1")).to_have_text("Question 3 of 6")
    labels_before = [page.locator(".scene").nth(k).get_attribute("data-robot") for k in range(4)]
    ready(page)
    page.locator('[data-action="play"]').first.click()
    play_all(page)
    first = page.locator("section[data-option]").first
    first_rating = page.locator('.rating[data-option="A"] input[value="3"]')
    first_rating.check()
    page.reload()
    expect(page.locator("h1")).to_have_text("Question 3 of 6")
    ready(page)
    # the step is shown as it was left: option A played and rated 3, the rest still to do
    expect(first).to_have_class("option played")
    assert first_rating.is_checked()
    assert page.locator("section.played").count() == 1
    assert page.locator('#test-form button[type="submit"]').is_disabled()
    assert [page.locator(".scene").nth(k).get_attribute("data-robot") for k in range(4)] == labels_before
    p.refresh_from_db()
    assert Answer.objects.filter(participant=p, kind="test").count() == 2
    assert flow.current_step(p).kind == "test" and flow.current_step(p).item == 2

    # a new tab with the same Prolific link lands on the same question
    tab = context.new_page()
    tab.clock.install()
    tab.goto(entry)
    expect(tab.locator("h1")).to_have_text("Question 3 of 6")
    expect(tab.locator("section.played")).to_have_count(1)
    tab.set_viewport_size({"width": 375, "height": 800})  # phone width: no sideways scrolling
    tab.reload()
    assert tab.evaluate("document.documentElement.scrollWidth") <= 375
    tab.screenshot(path=str(OUT / "test_phone.png"), full_page=True)
    tab.close()

    for j, label in zip(range(2, 6), "CDAB", strict=True):
        answer_test_by_keyboard(page, choose_label=label, rating=3 + j % 3)
    expect(page.locator("h1")).to_have_text("One more question")
    page.get_by_label("Merge into the right lane").check()
    page.get_by_label("Drive forward").check()
    page.get_by_role("button", name="Continue").click()
    expect(page.locator("h1")).to_have_text("About you")
    page.locator("#age").fill("29")
    page.get_by_label("Non-binary").check()
    assert not completed  # not sent back before the last answer is stored
    page.get_by_role("button", name="Finish").click()
    expect(page.locator("h1")).to_have_text("Thank you!")
    code = page.locator("#completion-code").inner_text()
    page.clock.run_for(4000)
    page.wait_for_url("https://app.prolific.com/**", timeout=60_000)  # a hang guard
    expect(page.locator("h1")).to_have_text("Prolific: submission complete")
    connections.close_all()  # the ORM calls above ran in Playwright's context: close its connection

    assert not errors, errors  # page errors and CSP violations
    p.refresh_from_db()
    assert completed == [f"https://app.prolific.com/submissions/complete?cc={code}"]
    assert p.completed_at is not None and p.completion_code == code and not p.excluded
    answers = {(a.kind, a.item): a for a in Answer.objects.filter(participant=p)}
    assert len(answers) == len(flow.steps_for(p)) - 1
    for j, (label, rating) in enumerate(zip("ABCDAB", [6, 4, 5, 3, 4, 5], strict=True)):
        a = answers[("test", j)]
        shown = p.option_orders[j]
        chosen = shown["ABCD".index(label)]
        assert a.data["choice"] == chosen and a.data["ratings"] == [rating] * 4 and a.data["order"] == shown
        star = demo_study.test_set[j]["options"][chosen]["is_theta_star"]
        assert a.confidence_score == (rating if star else -rating)
    assert answers[("attention", None)].data == {"goals": ["forward", "merge"], "passed": True}
    assert answers[("demographics", None)].data == {"age": 29, "gender": "non-binary"}
    for name in ("training.png", "training_trail.png", "test.png", "test_phone.png"):
        assert (OUT / name).stat().st_size > 10_000
