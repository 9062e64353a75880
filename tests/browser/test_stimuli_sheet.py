"""The stimulus sheet in a real browser (Debian's Chromium through Playwright, headless): a closed
study with the paper's nine conditions on the tiny table, before anyone opens it.  Every canvas
(each training example, each test option) has drawn its whole drive with the autonomous car in
it, theta*'s option is marked once per test, a Play starts that scene's animation (the frame
changes), and the whole page goes to test-output/stimuli_sheet.png to look at."""
from __future__ import annotations

from pathlib import Path

import pytest
from django.urls import reverse

from tests.conftest import PAPER_SEQUENCES

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# Per canvas: how many distinct colours it holds, how many pixels are not transparent, and how
# many are near the autonomous car's yellow (--scene-robot), the drawing of the drive.
PIXELS = """() => [...document.querySelectorAll(".cell canvas")].map((canvas) => {
  const d = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
  const robot = getComputedStyle(document.documentElement).getPropertyValue("--scene-robot").trim();
  const [R, G, B] = [1, 3, 5].map((i) => parseInt(robot.slice(i, i + 2), 16));
  const colours = new Set();
  let opaque = 0, yellow = 0;
  for (let i = 0; i < d.length; i += 4) {
    if (d[i + 3] === 0) continue;
    opaque++;
    colours.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
    if (Math.abs(d[i] - R) + Math.abs(d[i + 1] - G) + Math.abs(d[i + 2] - B) < 40) yellow++;
  }
  const cell = canvas.closest(".cell");
  return {name: cell.dataset.scene + ":" + cell.dataset.item + ":" + (cell.dataset.option ?? ""),
          pixels: canvas.width * canvas.height, opaque, colours: colours.size, yellow,
          mode: canvas.scene.mode};
})"""


def test_every_stimulus_is_drawn_and_plays(staff_cookie, make_study, live_server, browser):  # db first
    study = make_study("sheet", sequences=PAPER_SEQUENCES, is_open=False)  # looked at before opening
    n_examples = sum(len(c.training) for c in study.conditions.all())
    n_options = sum(len(t["options"]) for t in study.test_set)
    n_conditions, n_tests = study.conditions.count(), len(study.test_set)  # no ORM beside Playwright's loop
    assert not study.is_open and n_examples > 40 and n_options >= 8
    OUT.mkdir(exist_ok=True)
    shot = OUT / "stimuli_sheet.png"
    if shot.exists():
        shot.unlink()
    host = live_server.url.split("//")[1].split(":")[0]
    ctx = browser.new_context(viewport={"width": 1280, "height": 900})
    ctx.add_cookies([{"name": "sessionid", "value": staff_cookie, "domain": host, "path": "/"}])
    page = ctx.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    # reached from the study's dashboard page
    page.goto(live_server.url + reverse("dashboard_study", args=[study.slug]))
    page.click("#stimuli-link")
    page.wait_for_selector("body[data-ready='1']")
    assert page.url == live_server.url + reverse("dashboard_stimuli", args=[study.slug])
    assert page.locator(".sheet-section[data-condition]").count() == n_conditions
    assert page.locator(".test-row").count() == n_tests
    assert page.locator(".cell.theta-star .star-badge").count() == n_tests

    cells = page.evaluate(PIXELS)
    assert len(cells) == n_examples + n_options
    blank = [c for c in cells if c["opaque"] < 0.99 * c["pixels"] or c["colours"] < 6 or c["yellow"] < 20]
    assert not blank, blank[:5]
    assert {c["mode"] for c in cells} == {"trail"}  # a static contact sheet until played
    page.screenshot(path=str(shot), full_page=True)

    # one Play: that scene animates (frames change, away from the trail), the others stay still
    cell = page.locator(".test-row").first.locator(".cell").nth(1)
    before = cell.locator("canvas").evaluate("c => c.toDataURL()")
    cell.locator('[data-action="play"]').click()
    page.wait_for_function("c => c.scene.mode === 'frame' && c.scene.t > 0.5",
                           arg=cell.locator("canvas").element_handle(), timeout=60_000)  # a hang guard
    first = cell.locator("canvas").evaluate("c => [c.toDataURL(), c.scene.t]")
    page.wait_for_timeout(400)
    second = cell.locator("canvas").evaluate("c => [c.toDataURL(), c.scene.t]")
    assert first[0] != before and second[0] != first[0] and second[1] > first[1]
    assert cell.get_attribute("data-state") == "playing"
    others = page.evaluate("() => [...document.querySelectorAll('.cell canvas')].filter("
                           "(c) => c.scene.mode !== 'trail').length")
    assert others == 1
    assert errors == []
    assert shot.exists() and shot.stat().st_size > 50_000
