"""The study page's simulated pilot in Chromium: the learner models' predicted scores for a
demo-table study (computed as the study job computes them) and a power table re-planned for another model and
lapse rate through the form.  Screenshot: test-output/pilot_predictions.png."""
from __future__ import annotations

from pathlib import Path

import pytest

from precompute.sequences import pilot_matrix
from studyapp.researcher.studies import make_study, store_pilot
from teaching.api import TrajectoryTable

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = pytest.mark.browser


def test_the_pilots_predictions_in_chromium(staff_page, live_server, demo_table):
    study = make_study(demo_table, "pilot-page")
    conditions = {c.name: c.env_ids for c in study.conditions.all()}
    store_pilot(study, pilot_matrix(TrajectoryTable.load(demo_table), conditions, test_set=study.test_set))
    OUT.mkdir(exist_ok=True)
    page, errors = staff_page
    assert page.goto(f"{live_server.url}/dashboard/{study.slug}/").status == 200
    table = page.locator("#predicted-scores")
    assert table.locator("tbody tr").count() == len(conditions)
    assert table.locator("thead th").count() == 1 + 8  # the condition and the eight learner models
    # by default the power table plans for det-euclidean's (approx*'s) predicted effects at ε = 0.1
    power = page.locator("#power-table")
    assert power.locator('tr[data-effect="det-euclidean vs exact, predicted by det-euclidean"]').count() == 1
    page.select_option("#id_model", "prob-reward")
    page.fill("#id_lapse", "0.3")
    page.get_by_role("button", name="Update").click()
    page.wait_for_load_state()
    assert "lapse rate ε = 0.3" in page.inner_text("#pilot")
    row = page.locator('#power-table tr[data-effect="coverage-approx* vs random, predicted by prob-reward"]')
    assert "predicted for prob-reward learners with lapse rate 0.3" in row.inner_text()
    page.locator("#pilot").screenshot(path=str(OUT / "pilot_predictions.png"))
    assert not errors, errors
