"""In Debian's Chromium, a study of the small grid test domain (tests/teaching/small_grid_domain.py),
made from its own teach output as `manage.py create_study` makes one, draws its training examples and
its tests' four options with a scene that extends the grid scene base (static/studyapp/scenes/grid.js):
no page error, no missing file, every canvas a picture, the field undistorted.  The domain and its
scene module exist only for this test: it registers the domain and serves tests/browser/static beside
the project's static files.  Screenshots: test-output/small_grid_<training|test>.png."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from playwright.sync_api import expect, sync_playwright

from studyapp.models import Participant, StepKind, Study
from studyapp.studies import build_study, spec_from_teach
from tests.browser.test_participant_flow import ready
from tests.browser.test_robot_words_browser import CANVAS_COLOURS
from tests.conftest import complete_flow
from tests.teaching import small_grid_domain as small
from tests.teaching.test_small_grid_domain import built_small_grid

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
OUT = Path(__file__).resolve().parents[2] / "test-output"
HERE = Path(__file__).resolve().parent

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# the first canvas's drawing size, CSS height and duration: the scene the page loaded, not another
SCENE = """() => { const c = document.querySelector(".scene canvas");
  return {w: c.scene.w, h: c.scene.h, cssH: c.getBoundingClientRect().height, duration: c.scene.duration}; }"""


def test_a_small_grid_study_draws_its_examples_and_options(transactional_db, live_server, settings,
                                                            tmp_path_factory, monkeypatch):
    settings.STATICFILES_DIRS = [*settings.STATICFILES_DIRS, HERE / "static"]  # its scene module
    monkeypatch.setenv("DJANGO_ALLOW_ASYNC_UNSAFE", "true")  # ORM calls beside Playwright's loop
    with small.registered():
        _, teach_dir = built_small_grid(tmp_path_factory)
        spec = {**spec_from_teach(teach_dir), "slug": "small-grid", "name": "Small grid",
                "recruitment": "prolific", "completion_code": "SMALL2026"}
        study = build_study(spec)
        Study.objects.filter(pk=study.pk).update(is_open=True)
        pid = "5f0c0ffee000000000000small"
        errors = []
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True)
            try:
                page = browser.new_context(viewport={"width": 1200, "height": 1000}).new_page()
                page.on("pageerror", lambda exc: errors.append(str(exc)))
                page.on("response", lambda r: errors.append(f"{r.status} {r.url}")
                        if r.status >= 400 and not r.url.endswith("/favicon.ico") else None)
                page.goto(f"{live_server.url}/s/{study.slug}/?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X")
                participant = complete_flow(Participant.objects.get(platform_pid=pid),
                                            stop_before=StepKind.TRAINING)
                OUT.mkdir(exist_ok=True)
                for kind in ("training", "test"):
                    if kind == "test":
                        participant = complete_flow(participant, stop_before=StepKind.TEST)
                    page.goto(f"{live_server.url}{participant.get_absolute_url()}")
                    ready(page)
                    expect(page.locator(".scene canvas").first).to_be_visible()
                    colours = page.evaluate(CANVAS_COLOURS)
                    assert len(colours) >= (1 if kind == "training" else 4) and min(colours) >= 3, colours
                    drawn = page.evaluate(SCENE)
                    # the 7 x 5 field at the canvas's width plus the label strip, unstretched
                    assert drawn["h"] == round(drawn["w"] * small.HEIGHT / small.WIDTH) + 16
                    assert abs(drawn["cssH"] - drawn["h"]) <= 1 and drawn["duration"] > 0
                    page.screenshot(path=str(OUT / f"small_grid_{kind}.png"), full_page=True)
            finally:
                browser.close()
    assert not errors, errors
