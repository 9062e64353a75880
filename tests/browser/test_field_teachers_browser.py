"""The field's teaching algorithms through the platform in Chromium: a researcher designs a study whose
conditions are SCOT, BEC scaffolding, HIGHLIGHTS and one of the paper's (exact), with tests graded by
difficulty; the in-process worker builds it; the study page shows the pilot's predicted score of each
condition; a participant goes through the SCOT condition; the analysis page reports the scores by
condition and by the tests' difficulty.  Screenshots: test-output/field_teachers_*.png.

The table is a saved synthetic one (300 environments × 80 θ, as tests/precompute/test_study_selectors.py
uses): SCOT's cover leaves a test environment of every difficulty, which the tiny table's 48 do not.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.analysis.simulate import simulate
from studyapp.models import Participant, Study
from teaching.domains.driving.synthetic import synthetic_table
from tests.browser.test_researcher_flow import complete_as_participant
from tests.precompute.conftest import celery_app_inprocess, celery_app_with, inprocess_worker  # noqa: F401

OUT = Path(__file__).resolve().parents[2] / "test-output"
SLUG = "field-teachers"
CONDITIONS = ("exact", "scot", "bec-scaffold", "highlights")

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def tables_dir(tmp_path, settings):
    """The designer's table list: one saved synthetic table."""
    synthetic_table(300, 80, n_candidates=6, seed=4).save(tmp_path / "synthetic")
    settings.TABLES_DIR = tmp_path
    return tmp_path


def design(page, base: str) -> None:
    page.goto(f"{base}/precompute/design/")
    expect(page.locator("#id_table option").first).to_contain_text("300 environments × 80 θ")
    page.fill("#id_slug", SLUG)
    page.fill("#id_name", "The field's teachers")
    for box in page.locator("input[name=conditions]").all():
        box.set_checked(box.get_attribute("value") in CONDITIONS)
    page.fill("#id_bec_scaffold_k", "1")  # a parameter, on its condition's row
    page.fill("#id_highlights_k", "3")
    page.select_option("#id_test_difficulty", "medium")
    page.fill("#id_target_per_condition", "3")
    summary = page.locator("[data-design-summary]")
    expect(summary).to_contain_text("Conditions (4)")
    expect(summary).to_contain_text("bec-scaffold (")
    page.locator("#design-summary").screenshot(path=str(OUT / "field_teachers_summary.png"))
    page.get_by_role("button", name="Build", exact=True).click()
    expect(page.locator("#job-status")).to_have_text(re.compile("succeeded|failed"), timeout=240_000)
    assert page.locator("#job-status").inner_text() == "succeeded", page.locator("#job-error").inner_text()


def test_a_study_of_the_fields_teachers_from_designer_to_analysis(inprocess_worker, tables_dir,  # noqa: F811
                                                                    staff_page, live_server):
    page, errors = staff_page
    OUT.mkdir(exist_ok=True)
    design(page, live_server.url)

    study = Study.objects.get(slug=SLUG)
    assert [c.name for c in study.conditions.all()] == list(CONDITIONS)
    assert {t["difficulty"] for t in study.test_set} == {"medium"}
    page.goto(f"{live_server.url}/dashboard/{SLUG}/")
    experience = page.locator("#experience")  # what each condition's participants go through, before opening
    expect(experience.locator("tbody tr")).to_have_count(len(CONDITIONS))
    expect(experience).to_contain_text("of medium difficulty")
    experience.screenshot(path=str(OUT / "field_teachers_experience.png"))
    predicted = page.locator("#predicted-scores")
    assert [r.locator("th, td").first.inner_text() for r in predicted.locator("tbody tr").all()] == list(CONDITIONS)
    page.locator("#pilot").screenshot(path=str(OUT / "field_teachers_pilot.png"))
    page.get_by_role("button", name="Open study").click()
    expect(page.locator("#study-status")).to_have_text("open")

    # the other conditions hold simulated participants, SCOT none: the next arrival goes to SCOT
    simulate(study, n_per_condition=2, seed=3)
    Participant.objects.filter(study=study, condition__name="scot").delete()
    complete_as_participant(page.context.browser, live_server.url, SLUG)
    walker = Participant.objects.filter(study=study, condition__name="scot").get()
    assert walker.completed_at and not walker.excluded

    page.goto(f"{live_server.url}/dashboard/{SLUG}/analysis/")
    rows = page.locator("#table-difficulty tbody tr")
    expect(rows.first).to_be_visible()
    cells = [[c.inner_text() for c in r.locator("td").all()] for r in rows.all()]
    assert {(c[0], c[1]) for c in cells} == {(name, "medium") for name in CONDITIONS}, cells
    assert next(c for c in cells if c[0] == "scot")[2] == "1"  # the walker, the condition's one participant
    page.screenshot(path=str(OUT / "field_teachers_analysis.png"), full_page=True)
    assert not errors, errors
