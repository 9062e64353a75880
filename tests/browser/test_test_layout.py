"""The test page's layout: four options compared on a phone (each option's strip the screen's width,
one above another, one "play all" control) and on a laptop (the four stacked beside the answer
panel: the whole question down to "Next" without scrolling), with every control a participant
touches at least 44 px.  Screenshots at 390x844 and 1280x800 go to test-output/ (look at them)."""
from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.models import Answer
from studyapp.participant import flow
from studyapp.participant.assignment import assign
from tests.browser.test_participant_flow import open_on_fake_clock
from tests.conftest import complete_flow

OUT = Path(__file__).resolve().parents[2] / "test-output"
TOUCH_PX = 44

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def on_a_test(transactional_db, tmp_path, monkeypatch, make_study):
    """A participant standing on the first test of a study (answers recorded server-side)."""
    study = make_study("layout")
    p = assign(study, "prolific", "layout-1", platform_study_id="S", platform_session_id="X")
    p = complete_flow(p, stop_before="test")
    assert flow.current_step(p).kind == "test"
    return p


def sizes(page, selector):
    return page.eval_on_selector_all(selector, "els => els.map(e => { const r = e.getBoundingClientRect();"
                                               " return [r.width, r.height, r.top, r.bottom]; })")


@pytest.mark.parametrize("name, width, height", [("phone", 390, 844), ("laptop", 1280, 800)])
def test_four_options_compared_without_scrolling_and_44px_targets(on_a_test, live_server, name, width, height, browser):
    url = f"{live_server.url}{on_a_test.get_absolute_url()}"
    page, errors = open_on_fake_clock(browser, url, viewport={"width": width, "height": height},
                                      has_touch=(name == "phone"))
    expect(page.locator("h1")).to_have_text("Question 1 of 6")
    assert page.evaluate("document.documentElement.scrollWidth") <= width  # no sideways scrolling
    # every control a participant presses: at least 44 x 44 px
    for selector in (".tile span", ".option button", "[data-action=play-all]", "#test-form button[type=submit]"):
        boxes = sizes(page, selector)
        assert boxes, selector
        small = [b for b in boxes if b[0] < TOUCH_PX - 0.5 or b[1] < TOUCH_PX - 0.5]
        assert not small, (selector, small[:3])
    canvases = sizes(page, ".option canvas")
    assert len(canvases) == 4
    # each option's canvas is the reference width every canvas of the study is scaled to (scene.js)
    ref = float(page.evaluate("getComputedStyle(document.documentElement).getPropertyValue('--scene-ref-w')")
                .strip().removesuffix("px"))
    assert all(abs(c[0] - ref) < 0.5 for c in canvases), (ref, canvases)
    # one above another, each below the one before it (a road strip per option: scenes/driving.css)
    assert all(b[2] >= a[3] for a, b in zip(canvases, canvases[1:], strict=False)), canvases
    in_option = page.eval_on_selector_all(".option", "els => els.map(e => !!e.querySelector('.rating'))")
    if name == "phone":  # each strip nearly the screen's width, under its row of controls
        assert all(c[0] >= width - 30 for c in canvases), canvases
        assert in_option == [True] * 4  # each option's rating row under it, in reach of what it rates
        rows, strips = sizes(page, ".option .rating"), canvases
        assert all(0 <= row[2] - strip[3] < 80 for row, strip in zip(rows, strips, strict=True)), (rows, strips)
    else:  # the laptop: the whole question, down to its Next button, above the fold, every option whole
        assert in_option == [False] * 4  # the ratings stay together in the answer panel
        assert sizes(page, "#test-form button[type=submit]")[0][3] <= height
        assert all(c[3] <= height for c in canvases), canvases
        assert all(c[0] >= 600 for c in canvases)
    # "Play all four together" starts every animation and marks each played
    page.locator("[data-action=play-all]").click()
    page.clock.run_for(5600)
    expect(page.locator("section.played")).to_have_count(4)
    # each option keeps its whole path drawn once played (the study's keep_trails, on by default)
    expect(page.locator('.option [data-action="trail"][aria-pressed="true"]')).to_have_count(4)
    assert page.eval_on_selector_all(".option canvas", "cs => cs.map(c => c.scene.mode)") == ["trail"] * 4
    # "✓ played" never covers the canvas (its goal arrow, its labels): it sits beside or above it
    assert all(badge[0] > 0 for badge in sizes(page, ".played-flag"))
    covered = page.eval_on_selector_all(".option", """els => els.filter(el => {
        const b = el.querySelector(".played-flag").getBoundingClientRect();
        const c = el.querySelector("canvas").getBoundingClientRect();
        return b.left < c.right && c.left < b.right && b.top < c.bottom && c.top < b.bottom; }).length""")
    assert covered == 0
    page.locator('input[name="choice"][value="B"]').check()
    for row in page.locator(".rating").all():
        row.locator('input[value="5"]').check()
    expect(page.locator("#test-form button[type=submit]")).to_be_enabled()
    OUT.mkdir(exist_ok=True)
    page.screenshot(path=str(OUT / f"test_page_{name}_{width}x{height}.png"))
    assert not errors, errors


def test_a_study_may_leave_the_last_frame_instead(on_a_test, live_server, browser):
    """keep_trails off: an option that played shows its last frame, as the paper's videos ended; its Trail
    button still shows the path on demand."""
    type(on_a_test.study).objects.filter(pk=on_a_test.study_id).update(keep_trails=False)
    page, errors = open_on_fake_clock(browser, f"{live_server.url}{on_a_test.get_absolute_url()}",
                                      viewport={"width": 1280, "height": 800})
    page.locator("[data-action=play-all]").click()
    page.clock.run_for(5600)
    expect(page.locator("section.played")).to_have_count(4)
    assert page.eval_on_selector_all(".option canvas", "cs => cs.map(c => c.scene.mode)") == ["frame"] * 4
    expect(page.locator('.option [data-action="trail"][aria-pressed="true"]')).to_have_count(0)
    page.locator('.option[data-option="A"] [data-action="trail"]').click()
    assert page.eval_on_selector(".option canvas", "c => c.scene.mode") == "trail"
    assert not errors, errors


def answer_test(page, letter="B", rating="5"):
    page.wait_for_selector("body[data-ready]", state="attached")
    page.locator("[data-action=play-all]").click()
    page.clock.run_for(5600)
    page.locator(f'input[name="choice"][value="{letter}"]').check()
    for row in page.locator(".rating").all():
        row.locator(f'input[value="{rating}"]').check()


def test_a_stale_tab_recovers_by_itself(on_a_test, live_server, browser):
    """The same question open in two tabs, answered in the first: the second tab's answer is
    refused (the step moved on), and that tab goes to the current step, saying why."""
    url = f"{live_server.url}{on_a_test.get_absolute_url()}"
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    first, second = context.new_page(), context.new_page()
    for page in (first, second):
        page.clock.install()
        page.goto(url)
    answer_test(first, "B", "5")
    first.locator("#test-form button[type=submit]").click()
    expect(first.locator("h1")).to_have_text("Question 2 of 6")
    answer_test(second, "C", "2")  # a different answer to the same, already answered, question
    second.locator("#test-form button[type=submit]").click()
    expect(second.locator("h1")).to_have_text("Question 2 of 6")
    expect(second.locator(".notice")).to_have_text(flow.MOVED_ON)
    stored = Answer.objects.get(participant=on_a_test, kind="test", item=0)
    assert stored.data["ratings"] == [5, 5, 5, 5]  # the first tab's answer, unchanged
