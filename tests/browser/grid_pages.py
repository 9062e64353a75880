"""A participant of a grid domain's study walked to its first training and first test page in
Debian's Chromium, with the checks every grid scene must pass there (used by the tests of domains
registered only for a test: the small grid, a world from a file)."""
from __future__ import annotations

from pathlib import Path

from playwright.sync_api import expect

from studyapp.models import Participant, StepKind
from tests.browser.test_participant_flow import ready
from tests.browser.test_robot_words_browser import CANVAS_COLOURS
from tests.conftest import complete_flow

OUT = Path(__file__).resolve().parents[2] / "test-output"

# the first canvas's drawing size, CSS height and duration, and the page's scene module: the scene the
# page loaded, not another
SCENE = """() => { const c = document.querySelector(".scene canvas");
  return {w: c.scene.w, h: c.scene.h, cssH: c.getBoundingClientRect().height, duration: c.scene.duration,
          module: document.querySelector('meta[name="scene-module"]').content}; }"""


def walk_scene_pages(browser, live_server, study, pid: str, rows: int, cols: int, shot: str, check=None) -> list[str]:
    """Enter `study` (open, recruited on Prolific) as `pid`; on its first training page and its first
    test page check that the canvases are pictures (one, then four) of the `rows` x `cols` grid at the
    canvas's width plus the label strip, undistorted, then call check(kind, page, drawn) and save
    test-output/<shot>_<kind>.png.  Returns the page errors and failed requests seen."""
    errors = []
    page = browser.new_context(viewport={"width": 1200, "height": 1000}).new_page()
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("response", lambda r: errors.append(f"{r.status} {r.url}")
            if r.status >= 400 and not r.url.endswith("/favicon.ico") else None)
    page.goto(f"{live_server.url}/s/{study.slug}/?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X")
    participant = complete_flow(Participant.objects.get(platform_pid=pid), stop_before=StepKind.TRAINING)
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
        assert drawn["h"] == round(drawn["w"] * rows / cols) + 16
        assert abs(drawn["cssH"] - drawn["h"]) <= 1 and drawn["duration"] > 0
        if check is not None:
            check(kind, page, drawn)
        page.screenshot(path=str(OUT / f"{shot}_{kind}.png"), full_page=True)
    return errors
