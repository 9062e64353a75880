"""In Debian's Chromium, a participant who sends a test without a choice is told so in the study's own
robot's words (Domain.texts.choice_required): a yard's participant reads of deliveries, never of the
car's driving style.  One study of every registered domain, on its smallest table; on the way, its
scene draws every option of the test (a smoke test of each domain's scene module: no page error,
and every canvas holds a picture, not one flat colour).  A world that tests by showing the way (Lee et
al.'s three) is sent without a way instead, and is told to show it."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.models import Participant, StepKind, Study
from studyapp.researcher.studies import build_study
from teaching.core.build import build_table
from teaching.core.domain import domain_names, get_domain
from teaching.core.table import TrajectoryTable
from tests.browser.test_participant_flow import ready
from tests.conftest import built_once, complete_flow
from tests.studyapp.test_stimuli import real_spec, smallest_preset

OUT = Path(__file__).resolve().parents[2] / "test-output"
CAR_WORDS = re.compile(r"\b(cars?|driv\w*|lanes?|highway|road|merg\w*|steer\w*)\b")

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# how many colours each canvas on the page holds (a canvas the scene never drew on holds one)
CANVAS_COLOURS = """() => [...document.querySelectorAll("canvas")].map((canvas) => {
  const data = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
  const seen = new Set();
  for (let i = 0; i < data.length && seen.size < 16; i += 4 * 7) seen.add(data.slice(i, i + 4).join());
  return seen.size;
})"""

# a show test sent without JavaScript's guard: no way shown, the disabled button out of the way
SEND_WITHOUT_A_WAY = """() => {
  document.querySelector('#show-form button[type="submit"]').disabled = false;
}"""
# what a participant's browser would send without JavaScript's guard: every option played and rated,
# the form's own `required` and the disabled button out of the way, no option chosen
SEND_WITHOUT_A_CHOICE = """() => {
  const form = document.querySelector("form[data-test-form]");
  form.noValidate = true;
  for (const box of form.querySelectorAll('input[name="played"]')) box.checked = true;
  form.querySelector('button[type="submit"]').disabled = false;
}"""


@pytest.mark.parametrize("name", domain_names())
def test_a_test_sent_without_a_choice_is_refused_in_the_studys_words(name, transactional_db, live_server,
                                                                     tmp_path_factory, browser):
    domain = get_domain(name)
    preset = smallest_preset(domain)
    out = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))
    study = build_study(real_spec(TrajectoryTable.load(out), out, slug=f"words-{name}"))
    Study.objects.filter(pk=study.pk).update(is_open=True)
    pid = f"5f0c0ffee00000000000{name[:4]}"
    page = browser.new_context(viewport={"width": 1200, "height": 1000}).new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{live_server.url}/s/{study.slug}/?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X")
    expect(page.locator("h1")).to_have_text("Consent to take part")
    # consent, instructions and training answered as the pages would: the first test is next
    participant = complete_flow(Participant.objects.get(platform_pid=pid), stop_before=StepKind.TEST)
    page.goto(f"{live_server.url}{participant.get_absolute_url()}")
    expect(page.locator("h1")).to_have_text(f"Question 1 of {len(study.test_set)}")
    ready(page)
    if study.test_kind == "show":
        colours = page.evaluate(CANVAS_COLOURS)
        assert len(colours) == 1 and colours[0] >= 3, colours  # the world, drawn, and no option
        page.evaluate(SEND_WITHOUT_A_WAY)
        page.locator('#show-form button[type="submit"]').click()
        refusal = page.locator(".save-error")
        expect(refusal).to_have_text("Please show the way: move the robot until it has finished, then continue.")
        OUT.mkdir(exist_ok=True)
        page.screenshot(path=str(OUT / f"refused_without_a_way_{name}.png"), full_page=True)
        assert not CAR_WORDS.search(page.locator("main").inner_text().lower())
        assert not errors, errors
        return
    assert domain.texts.question in page.locator(".lead").inner_text()
    colours = page.evaluate(CANVAS_COLOURS)
    assert len(colours) >= 4 and min(colours) >= 3, colours  # the four options, each drawn
    for letter in "ABCD":
        page.locator(f'.rating[data-option="{letter}"] input[value="4"]').check(force=True)
    page.evaluate(SEND_WITHOUT_A_CHOICE)
    page.locator('#test-form button[type="submit"]').click()
    refusal = page.locator(".save-error")
    expect(refusal).to_have_text(domain.texts.choice_required)
    OUT.mkdir(exist_ok=True)
    page.screenshot(path=str(OUT / f"refused_without_a_choice_{name}.png"), full_page=True)
    body = page.locator("main").inner_text()
    if name != "driving":
        assert not CAR_WORDS.search(refusal.inner_text().lower()), refusal.inner_text()
        assert not CAR_WORDS.search(body.lower()), body
    assert not errors, errors
    participant.refresh_from_db()
    assert not participant.answers.filter(kind=StepKind.TEST).exists()  # nothing was stored


def test_the_yards_participant_reads_the_yards_words():
    """What the Chromium test above expects of the gridworld, written out."""
    texts = get_domain("gridworld").texts
    assert texts.choice_required == "Please choose the delivery that matches the robot's preferences."
    assert not CAR_WORDS.search(texts.choice_required.lower())
