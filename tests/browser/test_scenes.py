"""The animation's camera shows the interaction: for every training example and every test option
of the demo study, and of a study on a real table, every frame while the other car is within the
interaction range has both cars inside the canvas, and a frame where it is further away marks it at
the edge with its distance.  The real static/studyapp/scenes/driving.js draws them in Debian's
Chromium, on canvases of the widths participants get (a phone's option strip, a laptop's, a
training page).  And it draws the road, the lanes and the cars with the sizes the scene data carry,
not sizes of its own."""
from __future__ import annotations

from pathlib import Path

import pytest

from studyapp.scenes import palette_css
from studyapp.trajectories import drawn_scene
from teaching.domains.driving.domain import DOMAIN as DRIVING
from teaching.domains.driving.page import scene_sizes

OUT = Path(__file__).resolve().parents[2] / "test-output"
INTERACTION_FT = 150  # scenes/driving.js

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# For every stimulus and canvas width: draw the frame at each row time and report where the cars
# landed (scene.lastFrame) against the canvas, and which marks it drew (the off-view car's arrow and tag).
CHECK = """async ({stimuli, widths}) => {
  const { Scene } = await import("/static/studyapp/scenes/driving.js");
  const out = [];
  for (const width of widths) {
    const canvas = document.createElement("canvas");
    canvas.style.width = width + "px";
    document.body.append(canvas);
    for (const s of stimuli) {
      const scene = new Scene(canvas, s.env, s.robot);
      const gaps = s.robot.map((r, k) => Math.abs(s.env.other[k][1] - r[1]));
      for (let k = 0; k < s.robot.length; k++) {
        scene.drawFrame(k * s.env.dt);
        const f = scene.lastFrame, inside = (p) => p && p[0] >= 0 && p[0] <= scene.w && p[1] >= 0 && p[1] <= scene.h;
        out.push({name: s.name, width, k, gap: gaps[k], near: gaps[k] <= %d, robot: inside(f.robot),
                  other: inside(f.other), shown: !!f.other, marks: scene.boxes.map((b) => b.kind)});
      }
    }
    canvas.remove();
  }
  return out;
}""" % INTERACTION_FT  # noqa: UP031  (%-format: the JavaScript braces stay single)


GRID = """async (stimuli) => {
  const { Scene } = await import("/static/studyapp/scenes/driving.js");
  const grid = document.createElement("div");
  grid.id = "closest-grid";
  grid.style.cssText = "display: grid; grid-template-columns: repeat(2, 480px); gap: 8px; padding: 8px";
  document.body.replaceChildren(grid);
  for (const s of stimuli) {
    const cell = document.createElement("div");
    cell.style.font = "11px sans-serif";
    cell.textContent = s.name;
    const canvas = document.createElement("canvas");
    canvas.style.width = "480px";
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
                        "env": drawn_scene(env, robot=False, domain=DRIVING), "robot": env["robot"]})
    for j, test in enumerate(study.test_set):
        for k, option in enumerate(test["options"]):
            out.append({"name": f"test {j + 1} option {k} (env {test['env_id']})",
                        "env": drawn_scene(test, robot=False, domain=DRIVING), "robot": option["robot"]})
    return out


def test_both_cars_are_on_the_canvas_whenever_they_interact(studies, live_server, browser):
    stimuli = [s for study in studies for s in stimuli_of(study)]
    real_tests = [s for s in stimuli_of(studies[1]) if s["name"].startswith("test")]
    assert len(stimuli) > 40
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{live_server.url}/s/{studies[0].slug}/")  # a participant page: the study's CSS colours
    page.add_style_tag(content=palette_css(DRIVING))  # the domain's palette (studyapp/scenes.py)
    page.add_style_tag(url=f"{live_server.url}/static/studyapp/scenes/driving.css")  # its option sizes
    frames = page.evaluate(CHECK, {"stimuli": stimuli, "widths": [364, 723, 1246]})
    # what participants see at the closest approach, to look at: the real study's test options
    page.evaluate(GRID, real_tests)
    OUT.mkdir(exist_ok=True)
    page.locator("#closest-grid").screenshot(path=str(OUT / "scenes_closest_approach.png"))
    assert not errors, errors
    assert len(frames) >= len(stimuli) * 3 * 20
    missing = [f for f in frames if not f["robot"] or (f["near"] and not f["other"])]
    assert not missing, missing[:5]
    # a car out of view is never silent: its arrow and its distance at the edge
    unmarked = [f for f in frames if not f["shown"] and not {"other-arrow", "other-label"} <= set(f["marks"])]
    assert not unmarked, unmarked[:5]
    assert any(not f["near"] for f in frames) and any(not f["shown"] for f in frames)


# One frame of a scene on a 300 px canvas, in colours set here (the classes below), and what it
# drew: per pixel of one column left of the cars and the labels (road and goal lane across the
# road) and of the robot's column and row (its car's width and length), the nearest of those colours.
SIZES = """async ({env, robot}) => {
  const palette = {grass: "#00ff00", road: "#000000", line: "#ffffff", goal: "#0000ff",
                   "goal-edge": "#00ffff", robot: "#ff0000", other: "#ff00ff", outline: "#808080",
                   "goal-hatch": "#0000ff"};  // the hatch drawn in the goal's colour: the lane's extent
  for (const [name, value] of Object.entries(palette)) {
    document.documentElement.style.setProperty(`--scene-${name}`, value);
  }
  const { Scene } = await import("/static/studyapp/scenes/driving.js");
  const canvas = document.createElement("canvas");
  canvas.style.width = "300px";
  document.body.replaceChildren(canvas);
  const scene = new Scene(canvas, env, robot);
  scene.drawFrame(0);
  const hex = (v) => [1, 3, 5].map((i) => parseInt(v.slice(i, i + 2), 16));
  const rgb = Object.fromEntries(Object.entries(palette).map(([k, v]) => [k, hex(v)]));
  const ctx = canvas.getContext("2d");
  const classify = (x, y) => {
    const d = ctx.getImageData(Math.floor(x * scene.dpr), Math.floor(y * scene.dpr), 1, 1).data;
    let best = null, dist = Infinity;
    for (const [k, c] of Object.entries(rgb)) {
      const e = (d[0] - c[0]) ** 2 + (d[1] - c[1]) ** 2 + (d[2] - c[2]) ** 2;
      if (e < dist) { best = k; dist = e; }
    }
    return best;
  };
  const [rx, ry] = scene.lastFrame.robot;
  const line = (n, f) => Array.from({length: n}, (_, i) => f(i));
  return {w: scene.w, h: scene.h, robot: [rx, ry], xs: scene.s,
          top: line(scene.h, (y) => classify(100.5, y + 0.5)),  // right of the time label, left of the cars
          across: line(scene.h, (y) => classify(rx, y + 0.5)),
          along: line(scene.w, (x) => classify(x + 0.5, ry))};
}"""


def extent(row, *classes) -> tuple[int, int]:
    """First pixel of `classes` in `row` and the one past the last."""
    hits = [i for i, c in enumerate(row) if c in classes]
    return hits[0], hits[-1] + 1


def at(got: int, origin: float, ft: float, scale: float) -> bool:
    """Whether the pixel edge `got` is `ft` feet from `origin` px (within 3 px: lines, outlines)."""
    return abs(got - (origin + ft * scale)) <= 3


def test_the_drawing_follows_the_payloads_sizes(live_server, browser):
    """scenes/driving.js draws the road, the lanes and the cars with the sizes the scene data carry
    (drawn_scene's "world"), not sizes of its own: with wider lanes, a wider road and a bigger car
    in the payload the road, the merge goal lane and the robot's car are drawn that wide."""
    rows = 21
    robot = [[0.0, 12.5 * k, 1.5707963, 50.0, 0.0] for k in range(rows)]
    payload = {"goal": 0, "dt": 0.25, "robot": robot,
               "other": [[-12.0, 12.5 * k] for k in range(rows)]}  # beside the robot: the view is not squeezed
    today = scene_sizes()
    wide = {"lane_width": 16.0, "lane_centres": [-16.0, 0.0, 16.0], "road_half_width": 24.0,
            "car_length": 20.0, "car_width": 8.0}
    assert wide != today
    page = browser.new_page(viewport={"width": 800, "height": 600})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{live_server.url}/static/studyapp/study.css")  # same origin as scene.js, no page colours
    page.add_style_tag(content=palette_css(DRIVING))  # the domain's palette (studyapp/scenes.py)
    drawn = {}
    for name, world in (("today", today), ("wide", wide)):
        env = drawn_scene({**payload, "world": world}, robot=False, domain=DRIVING)
        drawn[name] = page.evaluate(SIZES, {"env": env, "robot": robot})
    assert not errors, errors
    for name, world in (("today", today), ("wide", wide)):
        d = drawn[name]
        s = d["xs"]  # px per ft (the study's one scale): the same along the road and across it
        mid, (rx, ry) = d["h"] / 2, d["robot"]  # the road's centre line runs across the canvas's middle
        assert rx == pytest.approx(d["w"] / 2) and ry == pytest.approx(mid)
        road = extent(d["top"], "road", "line", "goal")  # the road between the grass
        half = world["road_half_width"]
        assert at(road[0], mid, -half, s) and at(road[1], mid, half, s), (name, road)
        goal = extent(d["top"], "goal")  # merge right: the right lane
        right, lane = world["lane_centres"][-1], world["lane_width"]
        assert at(goal[0], mid, right - lane / 2, s) and at(goal[1], mid, right + lane / 2, s), (name, goal)
        car_x, car_y = extent(d["across"], "robot"), extent(d["along"], "robot")  # inside its outline
        assert at(car_x[0], ry, -world["car_width"] / 2, s) and at(car_x[1], ry, world["car_width"] / 2, s), (
            name, car_x)
        assert at(car_y[0], rx, -world["car_length"] / 2, s) and at(car_y[1], rx, world["car_length"] / 2, s), (
            name, car_y)
