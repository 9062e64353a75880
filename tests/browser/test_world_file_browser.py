"""In Debian's Chromium, a study of a grid world written only as a file (tests/teaching/domains/worlds/
key-room.toml), made from its own teach output as `manage.py create_study` makes one, draws its training
examples and its tests' four options with the scene every world from a file shares
(static/studyapp/scenes/world.js): no page error, no missing file, every canvas a picture in the
world's own colours, the grid undistorted.  Screenshots: test-output/world_file_<training|test>.png."""
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
from tests.teaching.domains.worlds import key_room

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = [pytest.mark.browser, pytest.mark.slow]

SCENE = """() => { const c = document.querySelector(".scene canvas");
  return {w: c.scene.w, h: c.scene.h, cssH: c.getBoundingClientRect().height, duration: c.scene.duration,
          module: document.querySelector('meta[name="scene-module"]').content}; }"""
# the puddle's colour in the canvas's pixels: the file's colour reached the page's palette and the scene
PUDDLE_PIXELS = """() => { const c = document.querySelector(".scene canvas");
  const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data; let n = 0;
  for (let i = 0; i < d.length; i += 4) if (d[i] === 0x1d && d[i + 1] === 0x4e && d[i + 2] === 0xd8) n++;
  return n; }"""


def test_a_study_of_a_world_from_a_file_draws_its_examples_and_options(transactional_db, live_server,
                                                                       tmp_path_factory, monkeypatch):
    monkeypatch.setenv("DJANGO_ALLOW_ASYNC_UNSAFE", "true")  # ORM calls beside Playwright's loop
    with key_room.registered() as domain:
        _, teach_dir = key_room.built(tmp_path_factory)
        spec = {**spec_from_teach(teach_dir), "slug": "key-room", "name": "Key room",
                "recruitment": "prolific", "completion_code": "KEY2026"}
        study = build_study(spec)
        Study.objects.filter(pk=study.pk).update(is_open=True)
        pid = "5f0c0ffee00000000000keyroom"
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
                    assert drawn["module"].endswith("/scenes/world.js")
                    # the 7 x 5 world at the canvas's width plus the label strip, unstretched
                    assert drawn["h"] == round(drawn["w"] * domain.world.height / domain.world.width) + 16
                    assert abs(drawn["cssH"] - drawn["h"]) <= 1 and drawn["duration"] > 0
                    page.click("text=Show trail") if kind == "training" else None
                    assert page.evaluate(PUDDLE_PIXELS) > 0
                    page.screenshot(path=str(OUT / f"world_file_{kind}.png"), full_page=True)
            finally:
                browser.close()
    assert not errors, errors
