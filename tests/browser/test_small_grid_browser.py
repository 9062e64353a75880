"""In Debian's Chromium, a study of the small grid test domain (tests/teaching/small_grid_domain.py),
made from its own teach output as `manage.py create_study` makes one, draws its training examples and
its tests' four options with a scene that extends the grid scene base (static/studyapp/scenes/grid.js):
no page error, no missing file, every canvas a picture, the field undistorted.  The domain and its
scene module exist only for this test: it registers the domain and serves tests/browser/static beside
the project's static files.  Screenshots: test-output/small_grid_<training|test>.png."""
from __future__ import annotations

from pathlib import Path

import pytest

from studyapp.models import Study
from studyapp.researcher.studies import build_study, spec_from_teach
from tests.browser.grid_pages import walk_scene_pages
from tests.teaching import small_grid_domain as small
from tests.teaching.test_small_grid_domain import built_small_grid

HERE = Path(__file__).resolve().parent

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def test_a_small_grid_study_draws_its_examples_and_options(transactional_db, live_server, settings,
                                                            tmp_path_factory, browser):
    settings.STATICFILES_DIRS = [*settings.STATICFILES_DIRS, HERE / "static"]  # its scene module
    with small.registered():
        _, teach_dir = built_small_grid(tmp_path_factory)
        spec = {**spec_from_teach(teach_dir), "slug": "small-grid", "name": "Small grid",
                "recruitment": "prolific", "completion_code": "SMALL2026"}
        study = build_study(spec)
        Study.objects.filter(pk=study.pk).update(is_open=True)
        # the 7 x 5 field at the canvas's width plus the label strip, unstretched
        errors = walk_scene_pages(browser, live_server, study, "5f0c0ffee000000000000small", small.HEIGHT, small.WIDTH,
                                  "small_grid")
    assert not errors, errors
