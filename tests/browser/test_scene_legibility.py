"""The scenes are legible, measured in Debian's Chromium on every training example and test option
of two built studies (the demo study and one on the tiny table):

* no two labels or marks of a canvas overlap, and none covers a car, at any row time, on a test
  option's canvas (a phone's and a laptop's) and on a training canvas (scenes/driving.js keeps every
  box it drew on the scene: scene.boxes, and the cars' as scene.cars);
* training and test are drawn at one scale: the px per ft measured from where the two cars land
  on the canvas (their screen gap over their gap in ft) differs by at most 15 % across every canvas
  of a study;
* the goal arrow is never covered, by a canvas label or by the page's "✓ played" badge;
* goal lane and road, and the two cars, stay apart in a greyscale screenshot (luminance contrast
  at least 3:1), and the canvas's and the legend's text has at least 4.5:1 (WCAG)."""
from __future__ import annotations

import io
from pathlib import Path

import pytest
from PIL import Image

from studyapp.participant.assignment import assign
from studyapp.scenes import palette_css
from teaching.domains.driving.domain import DOMAIN as DRIVING
from tests.browser.test_scenes import stimuli_of
from tests.conftest import complete_flow

OUT = Path(__file__).resolve().parents[2] / "test-output"
WIDTHS = [723, 1246]  # a test option's canvas at 1280 x 800 (--scene-ref-w) and the training page's

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# Every stimulus on every width: each row time's label boxes, and the px/ft measured from the cars'
# screen positions (lastFrame) against their positions in ft, wherever they are far enough apart.
COLLECT = """async ({stimuli, widths, span}) => {
  const { Scene } = await import("/static/studyapp/scenes/driving.js");
  const out = [];
  for (const width of widths) {
    const canvas = document.createElement("canvas");
    canvas.style.width = width + "px";
    document.body.append(canvas);
    for (const s of stimuli) {
      const scene = new Scene(canvas, {...s.env, study_span: span}, s.robot);
      const ys = [], xs = [], frames = [];
      for (let k = 0; k < s.robot.length; k++) {
        scene.drawFrame(k * s.env.dt);
        frames.push({k, boxes: scene.boxes.map((b) => ({...b})), cars: scene.cars.map((b) => ({...b})),
                     w: scene.w, h: scene.h});
        const f = scene.lastFrame, r = s.robot[k], o = s.env.other[Math.min(k, s.env.other.length - 1)];
        if (!f.other) continue;
        // the road runs left to right: along it is the screen's x, across it the screen's y
        if (Math.abs(o[1] - r[1]) >= 30) ys.push(Math.abs(f.other[0] - f.robot[0]) / Math.abs(o[1] - r[1]));
        if (Math.abs(o[0] - r[0]) >= 8) xs.push(Math.abs(f.other[1] - f.robot[1]) / Math.abs(o[0] - r[0]));
      }
      out.push({name: s.name, width, frames, ys, xs});
    }
    canvas.remove();
  }
  return out;
}"""


def overlap(a, b) -> bool:
    return (a["x"] < b["x"] + b["w"] and b["x"] < a["x"] + a["w"]
            and a["y"] < b["y"] + b["h"] and b["y"] < a["y"] + a["h"])


def test_labels_never_overlap_and_one_scale_per_study(studies, live_server, browser):
    inputs = {study.slug: {"stimuli": stimuli_of(study), "widths": WIDTHS,
                           "span": study.scene_view()["study_span"]}
              for study in studies}
    first = studies[0].slug
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{live_server.url}/s/{first}/")  # a participant page: the study's CSS
    page.add_style_tag(content=palette_css(DRIVING))  # the domain's palette (studyapp/scenes.py)
    page.add_style_tag(url=f"{live_server.url}/static/studyapp/scenes/driving.css")  # its option sizes
    drawn = {slug: page.evaluate(COLLECT, args) for slug, args in inputs.items()}
    assert not errors, errors
    kinds = set()
    for slug, canvases in drawn.items():
        assert len(canvases) > 20
        clashes, outside, n_boxes = [], [], 0
        for c in canvases:
            for f in c["frames"]:
                boxes = f["boxes"]
                n_boxes += len(boxes)
                kinds.update(b["kind"] for b in boxes)
                clashes += [(c["name"], c["width"], f["k"], a, b) for i, a in enumerate(boxes)
                            for b in boxes[i + 1:] + f["cars"] if overlap(a, b)]
                outside += [(c["name"], b) for b in boxes
                            if b["x"] < 0 or b["y"] < 0 or b["x"] + b["w"] > f["w"] or b["y"] + b["h"] > f["h"]]
        assert n_boxes > 1000
        assert not clashes, clashes[:3]
        assert not outside, outside[:3]
        # one scale: every measured px/ft of the study within 15 % (test options and training alike)
        for axis in ("ys", "xs"):
            values = [(v, c["name"], c["width"]) for c in canvases for v in c[axis]]
            assert len({w for _, _, w in values}) == len(WIDTHS), axis  # measured on both kinds of canvas
            lo, hi = min(values), max(values)
            assert hi[0] <= 1.15 * lo[0], (slug, axis, lo, hi)
    assert {"time-label", "goal-label", "goal-arrow", "other-label", "other-arrow"} <= kinds, kinds


def grey(png: bytes) -> Image.Image:
    return Image.open(io.BytesIO(png)).convert("L")  # a greyscale screenshot: luma only


def luminance(g: float) -> float:
    c = g / 255
    return c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4


def contrast(a: float, b: float) -> float:
    la, lb = sorted((luminance(a), luminance(b)))
    return (lb + 0.05) / (la + 0.05)


def css_contrast(fg: str, bg: str) -> float:
    def lum(rgb):
        c = [v / 255 for v in rgb]
        c = [v / 12.92 if v <= 0.03928 else ((v + 0.055) / 1.055) ** 2.4 for v in c]
        return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
    def parse(s):
        return [int(float(v)) for v in s[s.index("(") + 1:s.index(")")].split(",")[:3]]
    a, b = sorted((lum(parse(fg)), lum(parse(bg))))
    return (b + 0.05) / (a + 0.05)


@pytest.fixture
def on_training(transactional_db, make_study):
    study = make_study("legible", sequences={"both": [500, 5780, 12165]})
    p = assign(study, "prolific", "legible-1", platform_study_id="S", platform_session_id="X")
    return complete_flow(p, stop_before="training")


# Where a canvas drew: the goal lane, the road beside it and the cars (CSS px within the canvas)
WHERE = """() => {
  const canvas = document.querySelector(".scene canvas"), scene = canvas.scene;
  const gaps = scene.robot.map((r, k) => Math.abs(scene.env.other[k][1] - r[1]));
  scene.drawFrame(gaps.indexOf(Math.min(...gaps)) * scene.dt);
  const lanes = scene.world.lane_centres;
  const goalX = scene.env.goal === 0 ? lanes[lanes.length - 1] : lanes[1];
  const roadX = scene.env.goal === 0 ? lanes[1] : lanes[0];
  // the road runs left to right: a lane is a row of the canvas, at its centre's offset from the middle
  return {robot: scene.lastFrame.robot, other: scene.lastFrame.other, goal: scene.env.goal,
          goalY: scene.h / 2 + goalX * scene.s, roadY: scene.h / 2 + roadX * scene.s,
          boxes: scene.boxes, w: scene.w, h: scene.h, viewSpan: scene.viewSpan};
}"""


def test_goal_lane_and_cars_apart_in_greyscale_and_text_contrast(on_training, live_server, browser):
    page = browser.new_page(viewport={"width": 1280, "height": 900}, reduced_motion="reduce")
    page.goto(f"{live_server.url}{on_training.get_absolute_url()}")
    page.wait_for_selector("body[data-ready]", state="attached")
    w = page.evaluate(WHERE)
    # the page hands the scene the study's one scale (its scene-view block): a training canvas is drawn
    # at the span that holds every canvas of the study, not its own example's
    assert w["viewSpan"] == pytest.approx(on_training.study.scene_view()["study_span"], abs=0.1)
    canvas = page.locator(".scene canvas")
    shot = grey(canvas.screenshot())
    OUT.mkdir(exist_ok=True)
    shot.save(OUT / "scene_greyscale.png")
    legend = page.eval_on_selector_all(
        ".legend, .legend *, h1, p, strong", "els => els.map(e => [getComputedStyle(e).color, e.textContent])")
    assert w["other"] is not None, "both cars on the canvas at their closest approach"
    scale = shot.width / w["w"]  # the screenshot is in device pixels

    def band(y: float, avoid) -> float:
        """Median grey of a row strip at y (CSS px), away from the cars and labels."""
        vals = []
        for x in range(30, int(w["w"]) - 30, 3):
            if any(abs(x - a[0]) < 40 for a in avoid if a):
                continue
            for dy in (-2, 0, 2):
                vals.append(shot.getpixel((int(x * scale), int((y + dy) * scale))))
        vals.sort()
        return vals[len(vals) // 2]

    goal, road = band(w["goalY"], [w["robot"], w["other"]]), band(w["roadY"], [w["robot"], w["other"]])
    assert contrast(goal, road) >= 3, (goal, road)
    robot = shot.getpixel((int(w["robot"][0] * scale), int((w["robot"][1] + 3) * scale)))
    other = shot.getpixel((int(w["other"][0] * scale), int((w["other"][1] + 3) * scale)))
    assert contrast(robot, other) >= 3, (robot, other)
    # text: the page's legend and prose against the white card / page background
    for color, text in legend:
        assert css_contrast(color, "rgb(255, 255, 255)") >= 4.5, (text, color)
