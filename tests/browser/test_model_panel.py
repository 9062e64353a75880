"""The analysis page's learner-model panel in Chromium: a demo-table study answered by
participants who learn by det-euclidean, through the real flow; the page fetches the panel after the report,
which must rank det-euclidean first, show its figure decoded, and offer the CSV.  Screenshot:
test-output/model_panel.png."""
from __future__ import annotations

from pathlib import Path

import pytest
from django.urls import reverse

from studyapp.analysis.simulate import simulate
from studyapp.researcher.studies import make_study
from teaching.api import SimulatedLearner

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = pytest.mark.browser


def test_the_model_panel_in_chromium(staff_page, live_server, demo_table):
    study = make_study(demo_table, "model-panel")
    simulate(study, n_per_condition=14, seed=6, learner=SimulatedLearner("det-euclidean", 1.0, 0.1))
    OUT.mkdir(exist_ok=True)
    page, errors = staff_page
    assert page.goto(live_server.url + reverse("dashboard_analysis", args=[study.slug])).status == 200
    page.wait_for_selector("#model-fit-table", timeout=60_000)
    first = page.locator("#model-fit-table tbody tr").first.inner_text()
    assert first.split()[:2] == ["1", "det-euclidean"], first  # rank, model
    assert page.locator("#model-fit-table tbody tr").count() == 7  # eight models, the strategy pair as one
    assert "det-strategy = prob-strategy" in page.inner_text("#model-fit-table")
    size = page.eval_on_selector("#model-fit-panel figure img",
                                 "img => [img.complete, img.naturalWidth, img.naturalHeight]")
    assert size[0] and size[1] > 600 and size[2] > 250, size
    link = page.get_by_role("link", name="Download the table (CSV)")
    with page.expect_download() as download:
        link.click()
    assert download.value.suggested_filename == "model-panel-models.csv"
    page.locator("#model-fit-panel").screenshot(path=str(OUT / "model_panel.png"))
    assert not errors, errors
