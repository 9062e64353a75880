"""The gridworld through the whole platform: its table (built for real) -> `python -m
teaching teach` -> `manage.py create_study` from that output -> a participant completes the study in
Debian's Chromium (training animations and the four test options drawn by scenes/gridworld.js,
screenshots in test-output/ to look at) -> `manage.py analyze`.  A driving study lives in the same
database and the dashboard lists both, each with its domain.
"""
from __future__ import annotations

import io
import re
from pathlib import Path

import pytest
from django.core.management import call_command
from playwright.sync_api import expect

from studyapp.analysis.simulate import simulate
from studyapp.models import Answer, Participant, Study
from studyapp.researcher.studies import build_study, demo_spec
from teaching.api import get_domain
from tests.browser.test_participant_flow import h1, play_all, ready

OUT = Path(__file__).resolve().parents[2] / "test-output"
PID = "5f0c0ffee0000000000000cd"

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# what the yard's canvas draws for the robot at a cell centre (palette "robot") and a free cell ("free")
ROBOT_AT_START = """() => {
  const canvas = document.querySelector(".scene canvas");
  const s = canvas.scene;
  return {w: s.w, h: s.h, robot: s.lastFrame && s.lastFrame.robot, duration: s.duration,
          cssW: canvas.clientWidth, cssH: canvas.clientHeight};
}"""


@pytest.fixture
def studies(transactional_db, gridworld_teach, demo_table, monkeypatch):
    out = io.StringIO()
    call_command("create_study", str(gridworld_teach), "--slug", "yard", "--name", "Delivery robot",
                 "--recruitment", "prolific", "--completion-code", "YARD2026", stdout=out)
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    driving = build_study(demo_spec())
    yard = Study.objects.get(slug="yard")
    yard.is_open = True
    yard.save()
    return yard, driving


def test_a_gridworld_study_from_table_to_analysis(studies, live_server, tmp_path, browser):
    yard, driving = studies
    assert (yard.domain, driving.domain) == ("gridworld", "driving")
    n_tests = len(yard.test_set)
    texts = get_domain("gridworld").texts
    OUT.mkdir(exist_ok=True)
    page = browser.new_context(viewport={"width": 1200, "height": 1000}).new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("console", lambda msg: errors.append(msg.text)
            if msg.type == "error" and "Failed to load resource" not in msg.text else None)
    # every script, style sheet and scene module the pages ask for is there (the browser's own
    # favicon request aside)
    page.on("response", lambda r: errors.append(f"{r.status} {r.url}")
            if r.status >= 400 and not r.url.endswith("/favicon.ico") else None)
    page.clock.install()
    page.goto(f"{live_server.url}/s/yard/?PROLIFIC_PID={PID}&STUDY_ID=S&SESSION_ID=X")
    expect(page.locator("h1")).to_have_text("Consent to take part")
    assert texts.consent.split("\n\n")[0][:60] in page.content()  # the gridworld's default consent
    page.locator('button[value="yes"]').click()
    expect(page.locator("h1")).to_have_text("Instructions")
    assert "{#" not in page.content() and "{%" not in page.content()  # no template syntax shows
    body = page.locator("main").inner_text()
    assert "delivery robot" in body and not re.search(r"\b(cars?|lanes?|road|driv\w*)\b", body.lower()), body
    assert page.locator(".legend .swatch").count() == len(texts.legend)
    page.screenshot(path=str(OUT / "gridworld_instructions.png"), full_page=True)
    page.locator("button.primary").click()

    p = Participant.objects.get(platform_pid=PID)
    n_train = len(p.condition.training)
    for i in range(n_train):
        expect(page.locator("h1")).to_have_text(f"Example {i + 1} of {n_train}")
        ready(page)
        drawn = page.evaluate(ROBOT_AT_START)
        path = p.condition.training[i]["robot"]
        # the yard's scene, not the road's: the 8 x 6 yard's width and height plus the move label's
        # 16-px strip, drawn unstretched, and the animation lasts the path's moves
        assert drawn["h"] == round(drawn["w"] * 3 / 4) + 16 and abs(drawn["cssH"] - drawn["h"]) <= 1
        assert drawn["duration"] == pytest.approx((len(path) - 1) * 0.4)
        submit = page.locator('form[data-require-played] button[type="submit"]')
        assert submit.is_disabled()
        if i == 0:
            page.clock.run_for(int(drawn["duration"] * 500))
            page.screenshot(path=str(OUT / "gridworld_training.png"), full_page=True)
        if i == 1:  # pause: a click on the animation stops it where it is, a second click goes on from there
            scene = page.locator(".scene")
            page.clock.run_for(800)
            page.locator(".scene canvas").click()
            expect(scene).to_have_attribute("data-state", "paused")
            t_paused = page.evaluate("document.querySelector('.scene canvas').scene.t")
            page.clock.run_for(3000)
            assert page.evaluate("document.querySelector('.scene canvas').scene.t") == t_paused > 0
            assert submit.is_disabled()  # paused is not watched
            page.locator(".scene canvas").focus()
            page.keyboard.press("Space")  # and by keyboard
            expect(scene).to_have_attribute("data-state", "playing")
            page.clock.run_for(300)
            assert page.evaluate("document.querySelector('.scene canvas').scene.t") > t_paused
        play_all(page, int(drawn["duration"] * 1000) + 500)
        expect(submit).to_be_enabled()
        if i == 0:
            page.locator('[data-action="trail"]').click()
            page.screenshot(path=str(OUT / "gridworld_training_trail.png"))
        submit.click()

    for j in range(n_tests):
        expect(page.locator("h1")).to_have_text(f"Question {j + 1} of {n_tests}")
        ready(page)
        assert texts.question in page.locator(".lead").inner_text()
        page.locator('[data-action="play-all"]').click()
        play_all(page, 14000)
        if j == 0:
            page.screenshot(path=str(OUT / "gridworld_test.png"), full_page=True)
        if j == 1:  # a phone: the yards beside their buttons, nothing wider than the screen
            page.set_viewport_size({"width": 390, "height": 844})
            page.reload()
            ready(page)
            assert page.evaluate("document.documentElement.scrollWidth") <= 390
            page.screenshot(path=str(OUT / "gridworld_test_phone.png"), full_page=True)
            page.set_viewport_size({"width": 1200, "height": 1000})
        page.locator('input[name="choice"][value="A"]').check(force=True)
        for letter in "ABCD":
            page.locator(f'.rating[data-option="{letter}"] input[value="{5 if letter == "A" else 2}"]').check(
                force=True)
        page.locator('#test-form button[type="submit"]').click()

    expect(page.locator("h1")).to_have_text("One more question")
    assert texts.attention_question in page.locator("legend").inner_text()
    page.get_by_label("Carried a parcel to the drop-off D").check()
    page.get_by_role("button", name="Continue").click()
    expect(page.locator("h1")).to_have_text("About you")
    page.locator("#age").fill("41")
    page.get_by_label("Female").check()
    page.get_by_role("button", name="Finish").click()
    expect(page.locator("h1")).to_have_text("Thank you!")
    assert h1(page) == "Thank you!"
    assert not errors, errors
    p.refresh_from_db()
    assert p.completed_at and not p.excluded
    tests = Answer.objects.filter(participant=p, kind="test").order_by("item")
    assert tests.count() == n_tests and all(a.data["ratings"][a.chosen_option] == 5 for a in tests)

    # more participants (the simulated ones, through the same flow and the gridworld's attention check),
    # then one analysis per study, both in this one database
    simulate(yard, n_per_condition=3, seed=4)
    simulate(driving, n_per_condition=3, seed=5)
    n_yard = 1 + 3 * yard.conditions.count()
    for study, n in ((yard, n_yard), (driving, 3 * driving.conditions.count())):
        text = io.StringIO()
        call_command("analyze", study.slug, "--out", str(tmp_path / study.slug), stdout=text)
        assert f"{n} participants" in text.getvalue(), text.getvalue()
        assert "ANOVA" in text.getvalue() and (tmp_path / study.slug / "index.html").exists()
    excluded = Participant.objects.filter(study=yard, excluded=True).count()
    assert excluded == sum(1 for i in range(3 * yard.conditions.count()) if i % 7 == 3)  # simulate's inattentive


def test_one_dashboard_lists_both_domains(studies, staff_client):
    yard, driving = studies
    html = staff_client.get("/dashboard/").content.decode()
    for study in (yard, driving):
        row = html[html.index(f"({study.slug})"):][:200]
        assert f"<td>{study.domain}</td>" in row, row
    detail = staff_client.get(f"/dashboard/{yard.slug}/").content.decode()
    assert "Domain: <strong>gridworld</strong>" in detail
    sheet = staff_client.get(f"/dashboard/{yard.slug}/stimuli/").content.decode()
    assert "scenes/gridworld.js" in sheet and "--scene-mud:" in sheet


def test_the_stimulus_sheet_draws_the_yards(studies, staff_cookie, live_server, browser):
    """The staff stimulus sheet of the gridworld study: every example and option drawn as its whole path."""
    yard, _ = studies
    n_cells = sum(len(c.training) for c in yard.conditions.all()) + sum(len(t["options"]) for t in yard.test_set)
    host = live_server.url.split("//")[1].split(":")[0]
    ctx = browser.new_context(viewport={"width": 1280, "height": 900})
    ctx.add_cookies([{"name": "sessionid", "value": staff_cookie, "domain": host, "path": "/"}])
    page = ctx.new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{live_server.url}/dashboard/{yard.slug}/stimuli/")
    page.wait_for_selector("body[data-ready='1']")
    modes = page.evaluate("() => [...document.querySelectorAll('.cell canvas')].map((c) => c.scene.mode)")
    assert modes == ["trail"] * n_cells
    OUT.mkdir(exist_ok=True)
    page.screenshot(path=str(OUT / "gridworld_stimuli_sheet.png"), full_page=True)
    assert not errors, errors
