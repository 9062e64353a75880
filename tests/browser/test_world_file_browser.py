"""In Debian's Chromium, a study of a grid world written only as a file (tests/teaching/domains/worlds/
key-room.toml), made from its own teach output as `manage.py create_study` makes one, draws its training
examples and its tests' four options with the scene every world from a file shares
(static/studyapp/scenes/world.js): no page error, no missing file, every canvas a picture in the
world's own colours, the grid undistorted.  Screenshots: test-output/world_file_<training|test>.png."""
from __future__ import annotations

import pytest

from studyapp.models import Study
from studyapp.researcher.studies import build_study, spec_from_teach
from tests.browser.grid_pages import walk_scene_pages
from tests.teaching.domains.worlds import key_room

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# the puddle's colour in the canvas's pixels: the file's colour reached the page's palette and the scene
PUDDLE_PIXELS = """() => { const c = document.querySelector(".scene canvas");
  const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data; let n = 0;
  for (let i = 0; i < d.length; i += 4) if (d[i] === 0x1d && d[i + 1] === 0x4e && d[i + 2] === 0xd8) n++;
  return n; }"""


def check(kind, page, drawn):
    assert drawn["module"].endswith("/scenes/world.js")
    if kind == "training":
        page.click("text=Show trail")
    assert page.evaluate(PUDDLE_PIXELS) > 0


def test_a_study_of_a_world_from_a_file_draws_its_examples_and_options(transactional_db, live_server,
                                                                       tmp_path_factory, browser):
    with key_room.registered() as domain:
        _, teach_dir = key_room.built(tmp_path_factory)
        spec = {**spec_from_teach(teach_dir), "slug": "key-room", "name": "Key room",
                "recruitment": "prolific", "completion_code": "KEY2026"}
        study = build_study(spec)
        Study.objects.filter(pk=study.pk).update(is_open=True)
        # the 7 x 5 world at the canvas's width plus the label strip, unstretched
        errors = walk_scene_pages(browser, live_server, study, "5f0c0ffee00000000000keyroom", domain.world.height,
                                  domain.world.width, "world_file", check)
    assert not errors, errors
