"""A German study's pages in Debian's Chromium: what the scripts write (the play and trail buttons once
used, the hints, the labels drawn on the canvas, the test page's progress line, the offline banner) is
German, from the study's JavaScript catalog (locale/de/LC_MESSAGES/djangojs.po, compiled by
`make messages`).  Screenshot: test-output/german_training.png."""
from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.models import Participant, StepKind
from tests.browser.test_participant_flow import play_all, ready
from tests.conftest import complete_flow

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# every text drawn on a canvas, kept for the test (the scenes draw their labels with fillText)
RECORD_CANVAS_TEXTS = """
window.canvasTexts = [];
const fillText = CanvasRenderingContext2D.prototype.fillText;
CanvasRenderingContext2D.prototype.fillText = function (text, ...rest) {
  window.canvasTexts.push(String(text));
  return fillText.call(this, text, ...rest);
};
"""


def open_step(browser, live_server, study, pid, stop_before):
    """A new participant's page at the first step of kind `stop_before` (the steps before answered as
    the pages would): (context, page, errors)."""
    context = browser.new_context(viewport={"width": 1200, "height": 1000})
    page = context.new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.add_init_script(RECORD_CANVAS_TEXTS)
    page.clock.install()
    page.goto(f"{live_server.url}/s/{study.slug}/?PROLIFIC_PID={pid}&STUDY_ID=S&SESSION_ID=X")
    participant = complete_flow(Participant.objects.get(platform_pid=pid), stop_before=stop_before)
    page.goto(f"{live_server.url}{participant.get_absolute_url()}")
    ready(page)
    return context, page, errors


def test_a_german_studys_scripts_speak_german(transactional_db, make_study, live_server, browser):
    study = make_study("deutsch", language="de")
    OUT.mkdir(exist_ok=True)
    # training: the example played to its end, its trail shown
    context, page, errors = open_step(browser, live_server, study, "5f0c0ffee000000000000de1",
                                      StepKind.TRAINING)
    canvas = page.locator(".scene canvas")
    expect(canvas).to_have_attribute("title", "Klicken (oder Leertaste drücken), um die Animation "
                                     "anzuhalten oder fortzusetzen")
    play, trail = page.locator('[data-action="play"]'), page.locator('[data-action="trail"]')
    submit, hint = page.locator('form[data-require-played] button[type="submit"]'), page.locator(".hint")
    if page.locator(".scene").get_attribute("data-state") != "playing":
        play.click()  # reduced motion: the participant starts it
    play_all(page)
    expect(submit).to_be_enabled()
    expect(play).to_have_text("Erneut abspielen")
    expect(hint).to_have_text("Sie können das Beispiel erneut abspielen oder fortfahren.")
    texts = page.evaluate("window.canvasTexts")
    assert any(t.startswith(("Zug ", "t = ")) for t in texts), texts  # the move (or time) label
    trail.click()
    expect(trail).to_have_text("Verlauf ausblenden")
    assert page.evaluate("window.canvasTexts").pop().startswith("Verlauf: "), page.evaluate("window.canvasTexts")
    page.screenshot(path=str(OUT / "german_training.png"), full_page=True)
    trail.click()
    expect(trail).to_have_text("Verlauf zeigen")  # the page's own label (django.po), which the script toggles

    # the connection drops as the answer is sent: the banner says so in German; back online, it goes
    banner, heading = page.locator("[data-save-banner]"), page.locator("h1").inner_text()
    context.set_offline(True)
    submit.click()
    expect(banner).to_be_visible()
    expect(banner).to_have_text("Verbindung unterbrochen – Ihre Antwort bleibt erhalten und wird "
                                "automatisch gesendet; bitte lassen Sie diese Seite geöffnet.")
    page.screenshot(path=str(OUT / "german_offline_banner.png"))
    context.set_offline(False)
    expect(page.locator("h1")).not_to_have_text(heading)  # the next page
    expect(banner).to_be_hidden()
    assert Participant.objects.get(platform_pid="5f0c0ffee000000000000de1").answers.filter(
        kind=StepKind.TRAINING).exists()
    assert not errors, errors
    context.close()

    # a test: what is still to do, then one option played
    context, page, errors = open_step(browser, live_server, study, "5f0c0ffee000000000000de2",
                                      StepKind.TEST)
    hint = page.locator("form[data-test-form] [data-hint]")
    expect(hint).to_have_text("Zum Fortfahren: Option A, B, C, D abspielen; die passende Option wählen; "
                              "Option A, B, C, D bewerten.")
    option = page.locator('section[data-option="A"]')
    option.locator('[data-action="play"]').click()
    play_all(page)
    expect(option.locator('[data-action="play"]')).to_have_text("Nochmal A")
    expect(option.locator(".played-flag")).to_have_text("✓\u00a0gesehen")  # kept on one line in the narrow head
    expect(hint).to_have_text("Zum Fortfahren: Option B, C, D abspielen; die passende Option wählen; "
                              "Option A, B, C, D bewerten.")
    page.screenshot(path=str(OUT / "german_test.png"), full_page=True)
    assert not errors, errors
    context.close()
