"""What a participant sees: training waits for Play when the participant's system
asks for reduced motion, and a training example that repeats an earlier one says it does so on
purpose.  Debian's Chromium through Playwright, against the live test server."""
from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.participant import flow
from studyapp.participant.assignment import assign
from tests.browser.test_participant_flow import open_on_fake_clock
from tests.conftest import complete_flow

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
def test_training_autoplays_only_without_reduced_motion_and_repeats_are_announced(repeating, live_server, motion,
                                                                                  browser):
    url = f"{live_server.url}{repeating.get_absolute_url()}"
    page, errors = open_on_fake_clock(browser, url, viewport={"width": 1280, "height": 900}, reduced_motion=motion)
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
    assert not errors, errors


# Every target a participant can touch on the page: a radio or checkbox counts by the label that wraps
# it (the tiles' inputs cover their tile), everything else by its own box; hidden and off-screen
# ones (the "Skip to content" link until focused) are not targets.
TARGETS = """() => {
  const out = [];
  for (const el of document.querySelectorAll("a[href], button, input:not([type=hidden]), select, textarea, label")) {
    if (el.matches("input[type=radio], input[type=checkbox]") && el.closest("label")) continue;
    if (el.tagName === "LABEL" && !el.querySelector("input") && !el.htmlFor) continue;
    const r = el.getBoundingClientRect();
    if (r.width === 0 || r.height === 0 || r.right <= 0 || getComputedStyle(el).visibility === "hidden") continue;
    out.push({what: el.outerHTML.slice(0, 80), w: r.width, h: r.height});
  }
  return out;
}"""

# Text on the page against the background it sits on (the first opaque one up the tree), WCAG ratio.
TEXT_CONTRAST = """() => {
  const lum = (c) => { const v = c.match(/[\\d.]+/g).slice(0, 3).map((x) => x / 255)
    .map((x) => x <= 0.03928 ? x / 12.92 : ((x + 0.055) / 1.055) ** 2.4);
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]; };
  const opaque = (c) => !/rgba\\(.*,\\s*0\\)$/.test(c) && c !== "transparent";
  const out = [];
  for (const el of document.querySelectorAll("main *, header *")) {
    const own = [...el.childNodes].some((n) => n.nodeType === 3 && n.textContent.trim());
    if (!own || !el.getClientRects().length || el.closest("[disabled], .skip")) continue;
    let bg = el;
    while (bg && !opaque(getComputedStyle(bg).backgroundColor)) bg = bg.parentElement;
    const back = bg ? getComputedStyle(bg).backgroundColor : "rgb(255, 255, 255)";
    const [a, b] = [lum(getComputedStyle(el).color), lum(back)].sort();
    out.push({text: el.textContent.trim().slice(0, 40), ratio: (b + 0.05) / (a + 0.05)});
  }
  return out;
}"""


def rect(page, selector):
    return page.eval_on_selector_all(selector, "els => els.map(e => { const r = e.getBoundingClientRect(); return"
                                               " {top: r.top, bottom: r.bottom, left: r.left, right: r.right}; })")


def check_page(page, name, seen):
    page.wait_for_load_state()
    small = [t for t in page.evaluate(TARGETS) if t["w"] < 43.5 or t["h"] < 43.5]
    assert not small, (name, small[:4])
    low = [t for t in page.evaluate(TEXT_CONTRAST) if t["ratio"] < 4.5]
    assert not low, (name, low[:4])
    seen.append(name)
    page.screenshot(path=str(OUT / f"phone_{len(seen):02d}_{name}.png"), full_page=True)


@pytest.fixture
def arrival(transactional_db, make_study):
    return make_study("phone", sequences={"alpha": [500, 5780]})


def test_a_whole_flow_on_a_phone(arrival, live_server, browser):
    """390 x 844, DPR 2, touch: every page's targets at least 44 x 44 CSS px and its text at 4.5:1, and on
    each test the ratings and Next on one screen together (scrolled to Next), and each of the four
    animations, as wide as the screen allows, whole on screen when scrolled to (the options' strips are
    one above another: the four together are taller than a phone's screen)."""
    OUT.mkdir(exist_ok=True)
    seen = []
    context = browser.new_context(viewport={"width": 390, "height": 844}, device_scale_factor=2,
                                  has_touch=True, is_mobile=True)
    page = context.new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.clock.install()
    page.goto(f"{live_server.url}/s/{arrival.slug}/?PROLIFIC_PID=phone1&STUDY_ID=S&SESSION_ID=X")
    expect(page.locator("h1")).to_have_text("Consent to take part")
    check_page(page, "consent", seen)
    page.get_by_role("button", name="I agree, start the study").tap()
    expect(page.locator("h1")).to_have_text("Instructions")
    check_page(page, "instructions", seen)
    page.get_by_role("button", name="Start the examples").tap()
    for i in range(2):
        expect(page.locator("h1")).to_have_text(f"Example {i + 1} of 2")
        page.wait_for_selector("body[data-ready]", state="attached")
        page.clock.run_for(8000)
        check_page(page, "training", seen)
        next_button(page).tap()
    for j in range(6):
        expect(page.locator("h1")).to_have_text(f"Question {j + 1} of 6")
        page.wait_for_selector("body[data-ready]", state="attached")
        page.locator("[data-action=play-all]").tap()
        page.clock.run_for(8000)
        expect(page.locator("section.played")).to_have_count(4)
        submit = page.locator("#test-form button[type=submit]")
        # scrolled so that Next is on screen: every rating and Next are too
        submit.scroll_into_view_if_needed()
        boxes = {what: rect(page, sel) for what, sel in (("tile", ".answer .tile"),
                                                           ("next", "#test-form button[type=submit]"))}
        assert len(boxes["tile"]) == 4  # the choice; on a phone each option's ratings stand under it
        assert page.locator(".option .rating .tile").count() == 4 * 7
        if j == 0:
            page.screenshot(path=str(OUT / "phone_test_while_rating.png"))
        off = [(what, b) for what, bs in boxes.items() for b in bs
               if b["top"] < 0 or b["bottom"] > 844 or b["left"] < 0 or b["right"] > 390]
        assert not off, (j, off[:4])
        for k in range(4):  # each animation whole on screen once scrolled to
            page.locator(".option canvas").nth(k).scroll_into_view_if_needed()
            b = rect(page, ".option canvas")[k]
            # (within half a pixel: scrolling into view may leave a fraction of one below the edge)
            assert b["top"] >= 0 and b["bottom"] <= 844.5 and b["left"] >= 0 and b["right"] <= 390, (j, k, b)
            assert b["right"] - b["left"] >= 390 - 30, (j, k, b)
        page.locator('.choice input[value="B"]').check()
        for row in page.locator(".rating").all():
            row.locator('input[value="4"]').check()
        if j == 0:
            check_page(page, "test", seen)
        submit.tap()
    expect(page.locator("h1")).to_have_text("One more question")
    check_page(page, "attention", seen)
    page.get_by_label("Merge into the right lane").check()
    page.get_by_label("Drive forward").check()
    page.get_by_role("button", name="Continue").tap()
    expect(page.locator("h1")).to_have_text("About you")
    check_page(page, "demographics", seen)
    page.locator("#age").fill("30")
    page.locator('input[name="gender"]').first.check()
    page.route("https://app.prolific.com/**", lambda route: route.fulfill(status=200, body="done"))
    page.get_by_role("button", name="Finish").tap()
    expect(page.locator("h1")).to_have_text("Thank you!")
    check_page(page, "done", seen)
    assert not errors, errors
    assert seen == ["consent", "instructions", "training", "training", "test", "attention", "demographics", "done"]
