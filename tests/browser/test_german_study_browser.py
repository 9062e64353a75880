"""In Debian's Chromium: a German driving study and a German gridworld study walked through end to end,
every page read for English: no text of the German catalogs (their English msgids of two words or more,
split at placeholders) may show on any page a participant sees.  Screenshots: test-output/german_*.png."""
from __future__ import annotations

import io

import pytest
from django.core.management import call_command
from playwright.sync_api import expect

from studyapp.models import Participant, Study
from studyapp.researcher.studies import build_study, demo_spec
from teaching.api import get_domain
from tests.browser.grid_pages import OUT
from tests.browser.test_participant_flow import play_all, ready
from tests.studyapp.catalogs import english_leaks

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def german_studies(transactional_db, gridworld_teach, demo_table, monkeypatch):
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    # a study's name is the researcher's own text, shown on every page: a German study's is German
    driving = build_study({**demo_spec(), "language": "de", "name": "Wie fährt das Auto?"})
    call_command("create_study", str(gridworld_teach), "--slug", "hof", "--name", "Lieferroboter",
                 "--recruitment", "prolific", "--completion-code", "HOF2026", stdout=io.StringIO())
    Study.objects.filter(slug="hof").update(language="de", is_open=True)
    return driving, Study.objects.get(slug="hof")


def _read(page, seen: list[tuple[str, str]], name: str, shot: bool = True):
    """The page's visible text, kept for the English check; a screenshot of a page without animations (one
    with them waits for frames the fake clock holds back: test_german_scripts_browser.py shoots those)."""
    page.wait_for_load_state()
    seen.append((name, page.locator("body").inner_text()))
    if shot:
        page.screenshot(path=str(OUT / f"german_{name}.png"), full_page=True)


def answer_test(page):
    """Play the four options together to their end, choose A, rate all, go on (by mouse)."""
    ready(page)
    before = page.locator("h1").inner_text()
    page.locator('[data-action="play-all"]').click()
    play_all(page, 16000)
    page.locator('input[name="choice"][value="A"]').check(force=True)
    for letter in "ABCD":
        page.locator(f'.rating[data-option="{letter}"] input[value="{5 if letter == "A" else 2}"]').check(force=True)
    page.locator('#test-form button[type="submit"]').click()
    expect(page.locator("h1")).not_to_have_text(before)


def walk(page, url: str, study: Study, label: str) -> list[tuple[str, str]]:
    """Every step of `study` in the browser, each page's (name, text) collected."""
    seen: list[tuple[str, str]] = []
    page.goto(url)
    _read(page, seen, f"{label}_consent")
    page.locator('button[value="yes"]').click()
    _read(page, seen, f"{label}_instructions")
    page.locator("button.primary").click()
    p = Participant.objects.get(study=study)
    for i in range(len(p.condition.training)):
        ready(page)
        play_all(page, 16000)
        if i == 0:
            _read(page, seen, f"{label}_training", shot=False)
        page.locator('form[data-require-played] button[type="submit"]').click()
    for j in range(len(study.test_set)):
        if j == 0:
            ready(page)
            _read(page, seen, f"{label}_test", shot=False)
        answer_test(page)
    _read(page, seen, f"{label}_attention")
    for value in sorted(get_domain(study.domain).texts.attention_correct):
        page.locator(f'input[name="goals"][value="{value}"]').check()
    page.locator("button.primary").click()
    _read(page, seen, f"{label}_demographics")
    page.locator("button.primary").click()  # nothing filled in: the form's own messages
    page.fill("#age", "37")
    page.locator('input[name="gender"]').first.check()
    page.locator("button.primary").click()
    expect(page.locator("#completion-code")).to_be_visible()
    _read(page, seen, f"{label}_done")
    assert Participant.objects.get(pk=p.pk).completed_at is not None
    return seen


def test_german_studies_of_both_robots_speak_german_on_every_page(german_studies, live_server, browser):
    driving, yard = german_studies
    OUT.mkdir(exist_ok=True)
    for study, label, pid in ((driving, "driving", "de0000000000000000000001"),
                              (yard, "gridworld", "de0000000000000000000002")):
        page = browser.new_context(viewport={"width": 1200, "height": 1000}, locale="en-US").new_page()
        page.route("https://app.prolific.com/**", lambda route: route.fulfill(status=200, body="done"))
        errors = []
        page.on("pageerror", lambda exc, errors=errors: errors.append(str(exc)))
        page.clock.install()
        seen = walk(page, f"{live_server.url}/s/{study.slug}/?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X",
                    study, label)
        assert page.locator("html").get_attribute("lang") == "de"
        leaks = {name: english_leaks(text) for name, text in seen}
        leaks = {name: found for name, found in leaks.items() if found}
        assert not leaks, f"{label}: English on German pages: {leaks}"
        assert not errors, errors
