"""The worked example of a robot from outside the project (examples/hallway) in Debian's Chromium: its own
planner writes the table folder, import-table makes it a table, and a participant takes the study through
every page: training animations and four-option tests drawn by the top-down scene
(static/studyapp/scenes/topdown.js), on a laptop and on a phone.  Every page and JSON the site sends is
scanned for what would tell an environment or an objective apart (ids, θ indices, θ's weights).
Screenshots: test-output/imported_<training|test|test_phone>.png."""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import expect

from studyapp.models import Participant, Study
from studyapp.researcher.studies import build_study
from teaching.api import domain_names
from teaching.core.domain import unregister
from teaching.importing import registry
from teaching.importing.convert import import_table
from tests.browser.test_participant_flow import play_all, ready
from tests.studyapp.test_stimuli import real_spec

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "test-output"
PID = "5f0c0ffee00000000000hallway"
pytestmark = [pytest.mark.browser, pytest.mark.slow]

sys.path.insert(0, str(ROOT / "examples" / "hallway"))
import make_folder  # noqa: E402  (the example's own script, as its README runs it)

SCENE = """() => { const c = document.querySelector(".scene canvas");
  return {w: c.scene.w, h: c.scene.h, duration: c.scene.duration, robot: c.scene.lastFrame && c.scene.lastFrame.robot,
          module: document.querySelector('meta[name="scene-module"]').content}; }"""


@pytest.fixture
def hallway(tmp_path, transactional_db):
    """The example's folder (90 environments x 40 objectives), imported; its study open on Prolific."""
    make_folder.write_folder(tmp_path / "folder", n_envs=90, n_candidates=39, seed=0)
    path = tmp_path / "tables" / "hallway"
    table = import_table(tmp_path / "folder", path)
    study = build_study({**real_spec(table, path, slug="hallway"), "name": "A robot crossing a hallway"})
    Study.objects.filter(pk=study.pk).update(is_open=True)
    yield study, table
    if "hallway" in domain_names():
        unregister("hallway")
    registry.forget("hallway")


def two_by_two_then_stacked(page, name: str) -> None:
    """The test page's layout: on a laptop the first two options share a row; at 390 px they stack and nothing is
    wider than the screen.  Screenshots test-output/<name>_test.png and <name>_test_phone.png; the page is left
    reloaded at the laptop's size."""
    page.screenshot(path=str(OUT / f"{name}_test.png"), full_page=True)
    a, b = (page.locator(".option").nth(k).bounding_box() for k in (0, 1))
    assert abs(a["y"] - b["y"]) < 1 and b["x"] > a["x"] + a["width"] - 1
    page.set_viewport_size({"width": 390, "height": 844})
    page.reload()
    ready(page)
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
    a, b = (page.locator(".option").nth(k).bounding_box() for k in (0, 1))
    assert b["y"] >= a["y"] + a["height"] - 1  # stacked on a phone
    page.screenshot(path=str(OUT / f"{name}_test_phone.png"), full_page=True)
    page.set_viewport_size({"width": 1280, "height": 900})
    page.reload()
    ready(page)


def choose_a_and_rate_all(page) -> None:
    """Choose option A, rate every option 4, go on."""
    page.locator('input[name="choice"][value="A"]').check(force=True)
    for letter in "ABCD":
        page.locator(f'.rating[data-option="{letter}"] input[value="4"]').check(force=True)
    page.locator('#test-form button[type="submit"]').click()


def finish(page) -> None:
    """The attention check (an imported robot's: "A robot"), the demographics, and the thank-you page."""
    expect(page.locator("h1")).to_have_text("One more question")
    page.get_by_label("A robot", exact=True).check()
    page.get_by_role("button", name="Continue").click()
    expect(page.locator("h1")).to_have_text("About you")
    page.locator("#age").fill("29")
    page.get_by_label("Female").check()
    page.get_by_role("button", name="Finish").click()
    expect(page.locator("h1")).to_have_text("Thank you!")


def leaks(body: str, table) -> list[str]:
    """What in a page or a JSON answer would tell an environment or an objective apart."""
    found = [key for key in ('"env_id"', '"theta_index"', '"is_theta_star"', '"cluster"', '"env_class"')
             if key in body]
    weights = {repr(float(w)) for w in np.asarray(table.thetas).ravel() if len(repr(float(w))) > 6}
    found += [w for w in weights if w in body]
    return found


def test_a_participant_takes_the_hallway_study_and_nothing_tells_an_environment_apart(hallway, live_server,
                                                                                        browser):
    study, table = hallway
    OUT.mkdir(exist_ok=True)
    page = browser.new_context(viewport={"width": 1280, "height": 900}).new_page()
    errors, bodies = [], []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("response", lambda r: errors.append(f"{r.status} {r.url}")
            if r.status >= 400 and not r.url.endswith("/favicon.ico") else None)

    def keep(response):
        kind = response.headers.get("content-type", "")
        if response.status == 200 and response.url.startswith(live_server.url) and ("html" in kind or "json" in kind):
            bodies.append((response.url, response.body().decode()))

    page.on("response", keep)
    page.clock.install()
    page.goto(f"{live_server.url}/s/hallway/?PROLIFIC_PID={PID}&STUDY_ID=S&SESSION_ID=X")
    page.locator('button[value="yes"]').click()
    expect(page.locator("h1")).to_have_text("Instructions")
    assert "crosses a hallway" in page.locator("main").inner_text()  # the folder's own [texts]
    page.locator("button.primary").click()

    p = Participant.objects.get(platform_pid=PID)
    n_train = len(p.condition.training)
    for i in range(n_train):
        expect(page.locator("h1")).to_have_text(f"Example {i + 1} of {n_train}")
        ready(page)
        drawn = page.evaluate(SCENE)
        assert drawn["module"].endswith("/scenes/topdown.js")
        assert drawn["duration"] == pytest.approx(16 * 0.25 * 4 + 1)  # the folder's 17 s clock
        # the hallway's one view (11 m x 5.2 m) at the canvas's width, plus the label strip
        assert drawn["h"] == round(drawn["w"] * max(0.45, 5.2 / 11)) + 18
        if i == 0:
            page.clock.run_for(6000)
            page.screenshot(path=str(OUT / "imported_training.png"), full_page=True)
        play_all(page, int(drawn["duration"] * 1000) + 500)
        page.locator('form[data-require-played] button[type="submit"]').click()

    n_tests = len(study.test_set)
    for j in range(n_tests):
        expect(page.locator("h1")).to_have_text(f"Question {j + 1} of {n_tests}")
        ready(page)
        assert page.locator(".option .scene canvas").count() == 4
        page.locator('[data-action="play-all"]').click()
        play_all(page, 18000)
        if j == 0:
            two_by_two_then_stacked(page, "imported")
            page.locator('[data-action="play-all"]').click()
            play_all(page, 18000)
        choose_a_and_rate_all(page)

    finish(page)
    assert not errors, errors
    p.refresh_from_db()
    assert p.completed_at and not p.excluded

    assert len(bodies) > n_train + n_tests
    for url, body in bodies:
        assert not re.search(r"env|theta|θ", url.split("/s/hallway/")[-1].lower()), url
        assert not leaks(body, table), (url, leaks(body, table))
    # the scan would see a leak: a page that carried the test set as it is stored
    assert leaks(json.dumps(study.test_set), table)
