"""The animation's camera shows the interaction (issue 11): for every training example and every
test option of the demo study, and of a study on a real table, the frame drawn at the cars'
closest approach, and every frame while the other car is within the interaction range, has both
cars inside the canvas.  The real static/studyapp/scene.js draws them in Debian's Chromium, on
canvases of the widths participants get (a phone's test grid, a laptop's training page)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from playwright.sync_api import sync_playwright

from studyapp.studies import build_study, demo_spec
from studyapp.trajectories import drawn_scene
from teaching.table import TrajectoryTable
from tests.studyapp.test_stimuli import real_spec

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
OUT = Path(__file__).resolve().parents[2] / "test-output"
INTERACTION_FT = 150  # scene.js

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# For every stimulus and canvas width: draw the frame at each row time and at the closest approach,
# and report where the cars landed (scene.lastFrame) against the canvas.
CHECK = """async ({stimuli, widths}) => {
  const { Scene } = await import("/static/studyapp/scene.js");
  const out = [];
  for (const width of widths) {
    const canvas = document.createElement("canvas");
    canvas.style.width = width + "px";
    document.body.append(canvas);
    for (const s of stimuli) {
      const scene = new Scene(canvas, s.env, s.robot);
      const gaps = s.robot.map((r, k) => Math.abs(s.env.other[k][1] - r[1]));
      const closest = gaps.indexOf(Math.min(...gaps));
      for (let k = 0; k < s.robot.length; k++) {
        if (k !== closest && gaps[k] > %d) continue;
        scene.drawFrame(k * s.env.dt);
        const f = scene.lastFrame, inside = (p) => p && p[0] >= 0 && p[0] <= scene.w && p[1] >= 0 && p[1] <= scene.h;
        out.push({name: s.name, width, k, gap: gaps[k], robot: inside(f.robot), other: inside(f.other)});
      }
    }
    canvas.remove();
  }
  return out;
}""" % INTERACTION_FT  # noqa: UP031  (%-format: the JavaScript braces stay single)


GRID = """async (stimuli) => {
  const { Scene } = await import("/static/studyapp/scene.js");
  const grid = document.createElement("div");
  grid.id = "closest-grid";
  grid.style.cssText = "display: grid; grid-template-columns: repeat(4, 220px); gap: 8px; padding: 8px";
  document.body.replaceChildren(grid);
  for (const s of stimuli) {
    const cell = document.createElement("div");
    cell.style.font = "11px sans-serif";
    cell.textContent = s.name;
    const canvas = document.createElement("canvas");
    canvas.style.width = "220px";
    cell.append(canvas);
    grid.append(cell);
    const scene = new Scene(canvas, s.env, s.robot);
    const gaps = s.robot.map((r, k) => Math.abs(s.env.other[k][1] - r[1]));
    scene.drawFrame(gaps.indexOf(Math.min(...gaps)) * s.env.dt);
  }
}"""


def stimuli_of(study) -> list[dict]:
    """Every training example of every condition and every test option, as the pages get them."""
    out = []
    for c in study.conditions.all():
        for i, env in enumerate(c.training):
            out.append({"name": f"{c.name} example {i + 1} (env {env['env_id']})",
                        "env": drawn_scene(env, robot=False), "robot": env["robot"]})
    for j, test in enumerate(study.test_set):
        for k, option in enumerate(test["options"]):
            out.append({"name": f"test {j + 1} option {k} (env {test['env_id']})",
                        "env": drawn_scene(test, robot=False), "robot": option["robot"]})
    return out


@pytest.fixture
def studies(transactional_db, demo_table, tiny_table, monkeypatch):
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    demo = build_study(demo_spec())
    real = build_study(real_spec(TrajectoryTable.load(tiny_table), tiny_table))
    return [demo, real]


def test_both_cars_are_on_the_canvas_whenever_they_interact(studies, live_server):
    stimuli = [s for study in studies for s in stimuli_of(study)]
    real_tests = [s for s in stimuli_of(studies[1]) if s["name"].startswith("test")]
    assert len(stimuli) > 40
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True)
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        errors = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(f"{live_server.url}/s/{studies[0].slug}/")  # a participant page: the study's CSS colours
        frames = page.evaluate(CHECK, {"stimuli": stimuli, "widths": [160, 220, 320]})
        # what participants see at the closest approach, to look at: the real study's test options
        page.evaluate(GRID, real_tests)
        OUT.mkdir(exist_ok=True)
        page.locator("#closest-grid").screenshot(path=str(OUT / "scenes_closest_approach.png"))
        browser.close()
    assert not errors, errors
    assert len(frames) >= len(stimuli) * 3
    missing = [f for f in frames if not (f["robot"] and f["other"])]
    assert not missing, missing[:5]
