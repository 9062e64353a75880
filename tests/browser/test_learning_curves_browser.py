"""The analysis page's learning curves in Chromium: a demo-table study with an open-loop
condition and a closed-loop one, answered through the real flow by participants who learn by det-euclidean
(checks included); the page shows the closed loop's curve, its figure decoded and a row per check number.
Screenshot: test-output/learning_curves.png."""
from __future__ import annotations

from pathlib import Path

import pytest
from django.urls import reverse

from studyapp.analysis.simulate import simulate
from studyapp.models import Answer, StepKind
from studyapp.researcher.studies import build_study, table_spec
from teaching.api import SimulatedLearner, TrajectoryTable

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def test_the_learning_curves_in_chromium(staff_page, live_server, demo_table, settings, tmp_path):
    settings.VAR_DIR = tmp_path
    first = [int(e) for e in TrajectoryTable.load(demo_table, verify=False).env_ids[:5]]
    spec = table_spec(demo_table, slug="curves", sequences={"five": first})
    spec["conditions"].append({"name": "closed-loop", "closed_loop": {"max_examples": 6, "check_every": 2}})
    spec.update(name="Learning curves", target_per_condition=100)
    study = build_study(spec)
    simulate(study, n_per_condition=12, seed=7, learner=SimulatedLearner("det-euclidean", 1.0, 0.1))
    assert Answer.objects.filter(participant__study=study, kind=StepKind.CHECK).exists()
    OUT.mkdir(exist_ok=True)
    page, errors = staff_page
    assert page.goto(live_server.url + reverse("dashboard_analysis", args=[study.slug])).status == 200
    page.wait_for_selector("#learning-curves", timeout=60_000)
    rows = page.locator("#table-learning tbody tr")
    assert rows.count() == 3  # checks after examples 2, 4 and 6
    assert all(rows.nth(i).inner_text().startswith("closed-loop") for i in range(3))
    size = page.eval_on_selector("#fig-learning img", "img => [img.complete, img.naturalWidth, img.naturalHeight]")
    assert size[0] and size[1] > 300 and size[2] > 200, size
    top, bottom = page.locator("#learning-curves").bounding_box(), page.locator("#table-learning").bounding_box()
    height = bottom["y"] + bottom["height"] - top["y"] + 20
    page.screenshot(path=str(OUT / "learning_curves.png"), full_page=True,
                    clip={"x": 0, "y": top["y"] - 10, "width": 1280, "height": height})
    assert not errors, errors
