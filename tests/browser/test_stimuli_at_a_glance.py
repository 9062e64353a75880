"""Stimuli read at a glance, measured in Debian's Chromium on served studies of both domains (the
driving demo study and a gridworld study) at 1280 x 800 and 1920 x 1080 (DPR 1) and on a 390 x 844
phone (DPR 2, touch), on a participant's training page and first test page:

* driving: the robot car's drawn length at least 40 CSS px on the desktop sizes and 24 on the phone,
  at every row time of the training example and of each of the four options, and (drawn on canvases
  of those same widths) of every training example and every test option of the study; the length is
  read off the canvas's pixels (the yellow body along the car's axis) as well as the scene's geometry;
* gridworld: the yard's cells at least 32 px on the desktop sizes and 20 on the phone (the grid lines
  found in the pixels where the scene says they are);
* the road or the yard covering at least 60 % of every canvas (counted in pixels: grass, or the
  yard's surround and grid lines, is all that is not);
* one scale per study within 15 % across the training page and the test page (driving: px per ft
  from where the two cars land; gridworld: the cell size);
* no label overlaps another label or a car;
* at 1280 x 800 the four options, the choice, the ratings and Next on screen together, each option's
  canvas whole, and "Play all four together" plays all four.

Screenshots: test-output/glance_<domain>_<size>_<training|test>.png."""
from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.models import Study
from studyapp.participant.assignment import assign
from studyapp.researcher.studies import build_study, demo_spec
from studyapp.trajectories import drawn_scene
from teaching.core.build import build_table
from teaching.core.domain import get_domain
from teaching.core.table import TrajectoryTable
from tests.conftest import built_once, complete_flow
from tests.studyapp.test_stimuli import real_spec, smallest_preset

OUT = Path(__file__).resolve().parents[2] / "test-output"
SIZES = {"1280x800": {"viewport": {"width": 1280, "height": 800}},
         "1920x1080": {"viewport": {"width": 1920, "height": 1080}},
         "390x844": {"viewport": {"width": 390, "height": 844}, "device_scale_factor": 2, "has_touch": True,
                     "is_mobile": True}}
ROBOT_PX = {"1280x800": 40, "1920x1080": 40, "390x844": 24}  # the car's length, CSS px
CELL_PX = {"1280x800": 32, "1920x1080": 32, "390x844": 20}   # a yard's cell, CSS px
COVER = 0.60
SPREAD = 1.15

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# Per canvas and row time: what the scene drew (geometry) and, at some row times, what the pixels
# say: the robot's yellow body measured along its axis, and the share of the canvas that is not
# grass (the road), counted over columns (the least of any column: labels in the grass only add).
DRIVING = """async ({stimuli}) => {
  const { Scene } = await import(document.querySelector('meta[name="scene-module"]').content);
  const css = getComputedStyle(document.documentElement);
  const hex = (name) => {
    const v = css.getPropertyValue(name).trim();
    return [1, 3, 5].map((i) => parseInt(v.slice(i, i + 2), 16));
  };
  const [yellow, grass] = [hex("--scene-robot"), hex("--scene-grass")];
  const near = (d, i, c, tol) => Math.abs(d[i] - c[0]) + Math.abs(d[i + 1] - c[1]) + Math.abs(d[i + 2] - c[2]) <= tol;
  const view = JSON.parse(document.getElementById("scene-view").textContent);
  const measure = (scene, name) => {
    const ctx = scene.canvas.getContext("2d"), dpr = scene.dpr, n = scene.robot.length - 1;
    const out = {name, w: scene.w, h: scene.h, lengths: [], pixelLengths: [], covers: [], scales: [],
                 frames: []};
    for (let k = 0; k <= n; k++) {
      scene.drawFrame(k * scene.dt);
      const f = scene.lastFrame, r = scene.robot[k], o = scene.env.other[Math.min(k, scene.env.other.length - 1)];
      out.lengths.push(f.robotLength);
      out.frames.push({k, boxes: scene.boxes.map((b) => ({...b})), cars: scene.cars.map((b) => ({...b}))});
      const gap = Math.abs(o[1] - r[1]);  // ft along the road, drawn along the canvas's x
      if (f.other && gap >= 30) out.scales.push(Math.abs(f.other[0] - f.robot[0]) / gap);
      if (k % 4 !== 0 && k !== n) continue;
      const data = ctx.getImageData(0, 0, scene.canvas.width, scene.canvas.height).data, W = scene.canvas.width;
      const at = (x, y) => (Math.round(y * dpr) * W + Math.round(x * dpr)) * 4;
      const [cx, cy] = f.robot, a = f.robotAngle, reach = f.robotLength;
      let lo = null, hi = null;
      for (let t = -reach; t <= reach; t += 0.25) {
        const x = cx + t * Math.cos(a), y = cy + t * Math.sin(a);
        if (x < 0 || y < 0 || x >= scene.w || y >= scene.h) continue;
        if (near(data, at(x, y), yellow, 60)) { lo = lo === null ? t : lo; hi = t; }
      }
      // the yellow fill runs inside the 2-px outline, which adds 1 px at each end of the car's length
      out.pixelLengths.push(lo === null ? 0 : hi - lo + 2);
      let worst = 0;
      for (let c = 0; c < 24; c++) {
        const x = Math.round((c + 0.5) * scene.canvas.width / 24);
        let g = 0;
        for (let y = 0; y < scene.canvas.height; y++) if (near(data, (y * W + x) * 4, grass, 6)) g++;
        worst = Math.max(worst, g / scene.canvas.height);
      }
      out.covers.push(1 - worst);
    }
    return out;
  };
  const canvases = [...document.querySelectorAll(".scene canvas")];
  const page = canvases.map((c, i) => {
    const r = c.getBoundingClientRect();
    return {...measure(c.scene, `page canvas ${i}`), cssW: r.width, cssH: r.height};
  });
  for (const c of canvases) c.scene.drawFrame(0);
  // every stimulus of the study on a canvas as wide as this page's (the same page, the same CSS)
  const probe = document.createElement("canvas");
  probe.style.cssText = `display: block; width: ${canvases[0].getBoundingClientRect().width}px`;
  document.body.append(probe);
  const all = stimuli.map((s) => measure(new Scene(probe, {...view, ...s.env}, s.robot), s.name));
  probe.remove();
  return {page, all};
}"""

# Per canvas: the yard's cell and where it sits, and the pixels' share that is the yard's (not the
# surround's or the grid lines' colour), and whether the grid lines are where the cell size says.
GRIDWORLD = """async ({stimuli}) => {
  const { Scene } = await import(document.querySelector('meta[name="scene-module"]').content);
  const css = getComputedStyle(document.documentElement);
  const v = css.getPropertyValue("--scene-grid").trim(), grid = [1, 3, 5].map((i) => parseInt(v.slice(i, i + 2), 16));
  const isGrid = (d, i) => Math.abs(d[i] - grid[0]) + Math.abs(d[i + 1] - grid[1]) + Math.abs(d[i + 2] - grid[2]) <= 6;
  const measure = (scene, name) => {
    scene.drawFrame(0);
    const ctx = scene.canvas.getContext("2d"), dpr = scene.dpr, W = scene.canvas.width, H = scene.canvas.height;
    const data = ctx.getImageData(0, 0, W, H).data;
    let g = 0;
    for (let i = 0; i < data.length; i += 4) if (isGrid(data, i)) g++;
    const rows = scene.yard.cells.length, cols = scene.yard.cells[0].length;
    // the vertical grid lines along the yard's top row of pixels under its edge
    const y = Math.round((scene.oy + 1) * dpr);
    const lines = [];
    for (let c = 0; c <= cols; c++) {
      const x = Math.round((scene.ox + c * scene.cell - (c === cols ? 1 : 0)) * dpr);
      lines.push(isGrid(data, (y * W + x) * 4));
    }
    return {name, w: scene.w, h: scene.h, cell: scene.cell, cover: 1 - g / (W * H), lines: lines.every(Boolean),
            yard: cols * scene.cell * rows * scene.cell / (scene.w * scene.h), boxes: scene.boxes};
  };
  const canvases = [...document.querySelectorAll(".scene canvas")];
  const page = canvases.map((c, i) => {
    const r = c.getBoundingClientRect();
    return {...measure(c.scene, `page canvas ${i}`), cssW: r.width, cssH: r.height};
  });
  const probe = document.createElement("canvas");
  probe.style.cssText = `display: block; width: ${canvases[0].getBoundingClientRect().width}px`;
  document.body.append(probe);
  const all = stimuli.map((s) => measure(new Scene(probe, s.env, s.robot), s.name));
  probe.remove();
  return {page, all};
}"""


def stimuli_of(study, domain) -> list[dict]:
    """Every training example of every condition and every test option, as the pages get them."""
    out = []
    for c in study.conditions.all():
        for i, env in enumerate(c.training):
            out.append({"name": f"{c.name} example {i + 1}", "env": drawn_scene(env, robot=False, domain=domain),
                        "robot": env["robot"]})
    for j, test in enumerate(study.test_set):
        for k, option in enumerate(test["options"]):
            out.append({"name": f"test {j + 1} option {k}", "env": drawn_scene(test, robot=False, domain=domain),
                        "robot": option["robot"]})
    return out


@pytest.fixture
def served(transactional_db, demo_table, tmp_path_factory, monkeypatch):
    """The driving demo study and a gridworld study on its smallest table, both open."""
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    preset = smallest_preset(get_domain("gridworld"))
    table = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))
    studies = {"driving": build_study(demo_spec()),
               "gridworld": build_study(real_spec(TrajectoryTable.load(table), table, slug="glance-yard"))}
    Study.objects.filter(pk__in=[s.pk for s in studies.values()]).update(is_open=True)
    return studies


def overlaps(a, b) -> bool:
    return (a["x"] < b["x"] + b["w"] and b["x"] < a["x"] + a["w"]
            and a["y"] < b["y"] + b["h"] and b["y"] < a["y"] + a["h"])


def rect(page, selector) -> list[dict]:
    return page.eval_on_selector_all(selector, "els => els.map(e => e.getBoundingClientRect().toJSON())")


def check_driving(size, step, got) -> dict:
    """The robot's length, the road's share and the labels of every canvas; returns the figures."""
    least = ROBOT_PX[size]
    canvases = got["page"] + got["all"]
    for c in got["page"]:  # the page shows the drawing at its own size, unstretched
        assert abs(c["cssW"] - c["w"]) <= 1 and abs(c["cssH"] - c["h"]) <= 1, (size, step, c["name"])
    for c in canvases:
        where = (size, step, c["name"])
        assert min(c["lengths"]) >= least, (where, min(c["lengths"]))
        assert min(c["pixelLengths"]) >= least, (where, c["pixelLengths"])
        assert all(abs(p - g) <= 3 for p, g in zip(c["pixelLengths"], c["lengths"][::4], strict=False)), where
        assert min(c["covers"]) >= COVER, (where, c["covers"])
        for f in c["frames"]:
            for i, a in enumerate(f["boxes"]):
                inside = (a["x"] >= 0 and a["y"] >= 0
                          and a["x"] + a["w"] <= c["w"] + 0.5 and a["y"] + a["h"] <= c["h"] + 0.5)
                assert inside, (where, f["k"], a)
                clash = [b for b in f["boxes"][i + 1:] + f["cars"] if overlaps(a, b)]
                assert not clash, (where, f["k"], a, clash)
    return {"robot_px": min(min(c["lengths"]) for c in canvases),
            "robot_px_pixels": min(min(c["pixelLengths"]) for c in canvases),
            "cover": min(min(c["covers"]) for c in canvases),
            "scales": [s for c in canvases for s in c["scales"]]}


def check_gridworld(size, step, got) -> dict:
    least = CELL_PX[size]
    canvases = got["page"] + got["all"]
    for c in got["page"]:
        assert abs(c["cssW"] - c["w"]) <= 1 and abs(c["cssH"] - c["h"]) <= 1, (size, step, c["name"])
    for c in canvases:
        where = (size, step, c["name"])
        assert c["cell"] >= least and c["lines"], (where, c["cell"])
        assert c["cover"] >= COVER and c["yard"] >= COVER, (where, c["cover"], c["yard"])
        for i, a in enumerate(c["boxes"]):
            assert not [b for b in c["boxes"][i + 1:] if overlaps(a, b)], where
    return {"cell_px": min(c["cell"] for c in canvases), "cover": min(c["cover"] for c in canvases),
            "scales": [c["cell"] for c in canvases]}


def laptop_question_on_one_screen(page, height: int) -> None:
    """The four options whole, the choice, the ratings and Next on screen at once; "play all" plays all four."""
    boxes = {what: rect(page, sel) for what, sel in (("canvas", ".option canvas"), ("tile", ".answer .tile"),
                                                       ("next", "#test-form button[type=submit]"))}
    assert len(boxes["canvas"]) == 4 and len(boxes["tile"]) == 4 + 4 * 7
    off = [(what, b) for what, bs in boxes.items() for b in bs if b["top"] < 0 or b["bottom"] > height]
    assert not off, off[:3]
    page.clock.install()
    page.locator("[data-action=play-all]").click()
    page.clock.run_for(8000)
    expect(page.locator("section.played")).to_have_count(4)
    page.locator('input[name="choice"][value="B"]').check()
    for row in page.locator(".rating").all():
        row.locator('input[value="5"]').check()
    expect(page.locator("#test-form button[type=submit]")).to_be_enabled()
    played = [b for b in rect(page, ".played-flag") if b["width"] > 0]
    assert len(played) == 4  # "✓ played" beside each canvas, not over it
    for flag, canvas in zip(played, boxes["canvas"], strict=True):
        assert not (flag["left"] < canvas["right"] and canvas["left"] < flag["right"]
                    and flag["top"] < canvas["bottom"] and canvas["top"] < flag["bottom"])


@pytest.mark.parametrize("name", ["driving", "gridworld"])
def test_the_robot_and_what_it_meets_are_large_enough_to_judge(name, served, live_server, browser):
    study = served[name]
    domain = get_domain(name)
    stimuli = stimuli_of(study, domain)
    script, check = (DRIVING, check_driving) if name == "driving" else (GRIDWORLD, check_gridworld)
    OUT.mkdir(exist_ok=True)
    figures = {}
    for n, (size, options) in enumerate(SIZES.items()):
        p = assign(study, "prolific", f"glance-{name}-{n}", platform_study_id="S", platform_session_id="X")
        page = browser.new_page(**options, reduced_motion="reduce")
        errors = []
        page.on("pageerror", lambda exc, errors=errors: errors.append(str(exc)))
        scales = []
        for step in ("training", "test"):
            p = complete_flow(p, stop_before=step)
            page.goto(f"{live_server.url}{p.get_absolute_url()}")
            page.wait_for_selector("body[data-ready]", state="attached")
            assert page.evaluate("document.documentElement.scrollWidth") <= options["viewport"]["width"]
            got = page.evaluate(script, {"stimuli": stimuli})
            assert len(got["page"]) == (1 if step == "training" else 4)
            fig = check(size, step, got)
            scales += fig.pop("scales")
            figures[(size, step)] = fig
            page.screenshot(path=str(OUT / f"glance_{name}_{size}_{step}.png"))
            if step == "test" and size == "1280x800":
                laptop_question_on_one_screen(page, 800)
                page.screenshot(path=str(OUT / f"glance_{name}_{size}_rating.png"))
        assert not errors, errors
        # one scale: training and test, every canvas of the study, within 15 %
        assert scales and max(scales) <= SPREAD * min(scales), (size, min(scales), max(scales))
        figures[(size, "spread")] = round(max(scales) / min(scales) - 1, 3)
        page.close()
    print(name, figures)  # the figures docs/decisions.md quotes (pytest -s)
