"""A closed-loop condition with feedback in Debian's Chromium: the instructions say what check
questions are, examples, a check question answered on the test page, the feedback showing θ*'s trajectory
in that situation, and on to the final questions; every page a participant saw was decided once and the
decisions replay from the stored answers.  Screenshots: test-output/closed_loop_*.png."""
from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.models import LoopStep, Participant, StepKind
from studyapp.participant import closedloop, flow
from studyapp.researcher.studies import build_study, table_spec
from tests.browser.test_participant_flow import answer_test_by_keyboard, play_all, ready

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def loop_study(transactional_db, demo_table, settings, tmp_path):
    settings.VAR_DIR = tmp_path
    spec = table_spec(demo_table, slug="loop", sequences={})
    spec["conditions"] = [{"name": "closed-loop", "closed_loop": {"max_examples": 4, "check_every": 2,
                                                                  "feedback": True}}]
    spec.update(name="Closed loop", completion_code="LOOP2026")
    return build_study(spec)


def test_a_closed_loop_condition_with_feedback_in_chromium(loop_study, live_server, browser):
    OUT.mkdir(exist_ok=True)
    entry = f"{live_server.url}/s/{loop_study.slug}/?PROLIFIC_PID=loop-browser&STUDY_ID=s&SESSION_ID=x"
    page = browser.new_context(viewport={"width": 1200, "height": 1000}).new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("console", lambda msg: errors.append(msg.text) if "Content Security Policy" in msg.text else None)
    page.clock.install()
    page.goto(entry)
    page.locator('button[value="yes"]').click()
    expect(page.locator("h1")).to_have_text("Instructions")
    expect(page.locator("main")).to_contain_text("up to 4 examples")
    expect(page.locator("main")).to_contain_text("check question")
    page.screenshot(path=str(OUT / "closed_loop_instructions.png"), full_page=True)
    page.locator("button.primary").click()
    expect(page.locator("h1")).not_to_have_text("Instructions")
    p = Participant.objects.get(platform_pid="loop-browser")
    shots, headings = set(), []
    while not page.locator("h1").inner_text().startswith("Question 1 of"):
        heading = page.locator("h1").inner_text()
        headings.append(heading)
        ready(page)
        p.refresh_from_db()
        kind = flow.current_step(p).kind
        if kind == StepKind.CHECK:
            assert heading.startswith("Check question")
            if "check" not in shots:
                page.screenshot(path=str(OUT / "closed_loop_check.png"), full_page=True)
                shots.add("check")
            answer_test_by_keyboard(page, choose_label="B", rating=5)
        else:
            play_all(page, 6000)
            submit = page.locator('form[data-require-played] button[type="submit"]')
            expect(submit).to_be_enabled()
            name = "feedback" if kind == StepKind.FEEDBACK else "example"
            if name not in shots:
                page.screenshot(path=str(OUT / f"closed_loop_{name}.png"), full_page=True)
                shots.add(name)
            if len(headings) == 2:  # a reload shows the same decided example
                page.reload()
                expect(page.locator("h1")).to_have_text(heading)
                ready(page)
                play_all(page, 6000)
            submit.click()
        expect(page.locator("h1")).not_to_have_text(heading)
    assert not errors, errors
    assert shots == {"example", "check", "feedback"}
    assert headings[:2] == ["Example 1 of up to 4", "Example 2 of up to 4"]
    assert headings[2] == "Check question 1" and headings[3] == "The answer to the check question"
    steps = list(p.loop_steps.all())
    assert steps[-1].kind == LoopStep.DONE
    assert [s.kind for s in steps if s.kind != LoopStep.DONE] == [
        "check" if h.startswith("Check question") else "feedback" if h.startswith("The answer") else "example"
        for h in headings]
    assert closedloop.replay(p) == []


def test_a_slow_next_page_shows_a_progress_message_not_a_frozen_page(loop_study, live_server, browser):
    """The next step's page is held back (as a late decision would hold it): after a second the banner says
    it is being prepared; when it arrives the participant is on it, with nothing lost and no error."""
    OUT.mkdir(exist_ok=True)
    entry = f"{live_server.url}/s/{loop_study.slug}/?PROLIFIC_PID=slow-next&STUDY_ID=s&SESSION_ID=x"
    held = []
    page = browser.new_context(viewport={"width": 1200, "height": 900}).new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(entry)
    page.locator('button[value="yes"]').click()
    expect(page.locator("h1")).to_have_text("Instructions")

    def hold(route):  # the page after the instructions: answered later, by hand
        if route.request.method == "GET" and route.request.resource_type == "document" and not held:
            held.append(route)
        else:
            route.continue_()

    page.route("**/s/loop/**", hold)
    # While a navigation is pending Playwright does not read the old page, so the banner reports its
    # text on the console, which it delivers meanwhile.
    page.evaluate("""() => new MutationObserver(() => console.log("banner: " +
        document.querySelector("[data-save-banner]").textContent)).observe(
        document.querySelector("[data-save-banner]"), {childList: true, characterData: true, subtree: true})""")
    banner = []
    page.on("console", lambda msg: banner.append(msg.text) if msg.text.startswith("banner: ") else None)
    page.locator("button.primary").click()
    for _ in range(50):
        if held and any("preparing your next page" in b for b in banner):
            break
        page.wait_for_timeout(200)
    assert held and any("preparing your next page" in b for b in banner), (held, banner)
    held[0].continue_()
    expect(page.locator("h1")).to_have_text("Example 1 of up to 4", timeout=120_000)  # a hang guard
    assert not errors, errors
    p = Participant.objects.get(platform_pid="slow-next")
    assert p.position == 2 and p.loop_steps.count() == 1
