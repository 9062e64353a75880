"""The comprehension check in Debian's Chromium (headless): a participant answers one question wrongly, reads the
instructions again with that question named, answers again from there and goes on to the examples.  Screenshots
of the questions and of the instructions with the missed question marked go to QUIZ_SHOTS (default
/tmp/quiz-shots)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.models import Participant
from studyapp.participant import comprehension
from studyapp.researcher.studies import build_study, table_spec
from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET

SHOTS = Path(os.environ.get("QUIZ_SHOTS", "/tmp/quiz-shots"))

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def quiz_study(transactional_db, tiny_table):
    """A Prolific study on the tiny table asking its robot's own comprehension questions."""
    spec = table_spec(tiny_table, slug="quiz", sequences=SMALL_SEQUENCES, **TINY_TEST_SET)
    spec.update(name="Quiz", completion_code="QUIZ2026", recruitment="prolific", comprehension_check=True)
    return build_study(spec)


def answer(page, questions, wrong=()):
    """Tick each question's right choices, or a wrong one for the questions in `wrong`; then submit."""
    for i, q in enumerate(questions):
        picks = [next(k for k in range(len(q["choices"])) if k not in q["right"])] if i in wrong else q["right"]
        for k in picks:
            page.locator(f'input[name="q{i}"][value="{k}"]').check()
    page.get_by_role("button", name="Check my answers").click()


def test_fail_read_the_marked_instructions_then_pass(quiz_study, live_server, browser):
    SHOTS.mkdir(parents=True, exist_ok=True)
    questions = comprehension.questions_of(quiz_study)
    page = browser.new_context(viewport={"width": 1000, "height": 900}).new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("console", lambda msg: errors.append(msg.text) if "Content Security Policy" in msg.text else None)
    page.goto(f"{live_server.url}/s/quiz/?PROLIFIC_PID=quizzer&STUDY_ID=s&SESSION_ID=x")
    page.locator('button[value="yes"]').click()
    expect(page.locator("h1")).to_have_text("Instructions")
    page.get_by_role("button", name="Go to the questions").click()

    expect(page.locator("h1")).to_have_text("Questions about the instructions")
    expect(page.locator("fieldset.question")).to_have_count(len(questions))
    page.screenshot(path=str(SHOTS / "comprehension.png"), full_page=True)
    answer(page, questions, wrong={0})

    expect(page.locator("h1")).to_have_text("Instructions")
    missed = page.locator("#missed")
    expect(missed).to_contain_text(questions[0]["question"])
    expect(missed).to_contain_text("You have 2 more tries")
    expect(page.locator("#instructions")).to_be_visible()
    page.screenshot(path=str(SHOTS / "instructions_marked.png"), full_page=True)
    page.get_by_role("link", name="Answer the questions again").click()

    expect(page.locator("fieldset.question.missed")).to_have_count(1)
    expect(page.locator("fieldset.question").first).to_have_class("card question missed")
    page.screenshot(path=str(SHOTS / "comprehension_again.png"), full_page=True)
    answer(page, questions)
    expect(page.locator("h1")).to_contain_text("Example 1 of")
    assert not errors, errors
    p = Participant.objects.get(platform_pid="quizzer")
    assert list(p.comprehension_attempts.values_list("number", "passed")) == [(1, False), (2, True)]
