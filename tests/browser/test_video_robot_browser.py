"""The worked example's robot shown by its videos (examples/hallway, rendered by its own script with matplotlib
and ffmpeg) in Debian's Chromium: a participant takes the study through training videos and four-option video
tests (static/studyapp/scenes/video.js), on a laptop and on a phone.

The videos are fetched whole before the page can be used, with a progress bar (and a "Try again" when a fetch
fails); each is muted, without the browser's own controls, and counts as watched once played to its end; under
reduced motion nothing plays until the participant presses Play.  Every page, JSON answer and media URL the site
sends is scanned for what would tell an environment or an objective apart.
Screenshots: test-output/video_<loading|training|test|test_phone>.png."""
from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
from playwright.sync_api import expect

from studyapp.models import Participant, Study
from studyapp.researcher.studies import build_study
from teaching.api import domain_names
from teaching.core.domain import unregister
from teaching.importing import registry
from teaching.importing.convert import import_table
from tests.browser.test_imported_robot_browser import choose_a_and_rate_all, finish, leaks, two_by_two_then_stacked
from tests.browser.test_participant_flow import ready
from tests.studyapp.test_stimuli import real_spec

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "test-output"
PID = "5f0c0ffee0000000000000video"
SPEED = 16  # the clips play this much faster in the test (17 s each), as a participant's would, only sooner
MEDIA = re.compile(r"/s/hallway/p/[^/]+/media/[0-9a-f]{64}\.webm$")
pytestmark = [pytest.mark.browser, pytest.mark.slow]

sys.path.insert(0, str(ROOT / "examples" / "hallway"))
import make_folder  # noqa: E402  (the example's own script, as its README runs it)


@pytest.fixture(scope="module")
def filmed_folder(tmp_path_factory):
    """The example's folder with its videos (24 environments x 16 objectives), made once."""
    folder = tmp_path_factory.mktemp("hallway-video") / "folder"
    make_folder.write_folder(folder, n_envs=24, n_candidates=15, seed=0, videos=True)
    return folder


@pytest.fixture
def hallway(filmed_folder, tmp_path, transactional_db):
    path = tmp_path / "tables" / "hallway-video"
    table = import_table(filmed_folder, path)
    study = build_study({**real_spec(table, path, slug="hallway"), "name": "A robot crossing a hallway"})
    Study.objects.filter(pk=study.pk).update(is_open=True)
    yield study, table
    if "hallway-video" in domain_names():
        unregister("hallway-video")
    registry.forget("hallway-video")


def fast(page):
    """Every video of the page plays SPEED times faster (the test's time, not the participant's)."""
    page.evaluate(f"() => document.querySelectorAll('video').forEach((v) => {{ v.playbackRate = {SPEED}; }})")


def watched(page, n: int):
    """Wait until `n` videos have played to their end."""
    page.wait_for_function(f"() => document.querySelectorAll('.scene[data-state=\"ended\"]').length >= {n}",
                           timeout=60_000)


def test_a_participant_watches_the_hallway_videos_and_nothing_tells_an_environment_apart(hallway, live_server,
                                                                                          browser):
    study, table = hallway
    OUT.mkdir(exist_ok=True)
    page = browser.new_context(viewport={"width": 1280, "height": 900}).new_page()
    errors, bodies, media = [], [], []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("response", lambda r: errors.append(f"{r.status} {r.url}")
            if r.status >= 400 and not r.url.endswith("/favicon.ico") else None)

    def keep(response):
        kind = response.headers.get("content-type", "")
        if response.status == 200 and response.url.startswith(live_server.url):
            if "html" in kind or "json" in kind:
                bodies.append((response.url, response.body().decode()))
            elif "video" in kind:
                media.append(response.url)

    page.on("response", keep)
    # the first example's video is held back, so the progress bar is seen and the page waits for it
    held = []
    page.route("**/media/*", lambda route: held.append(route) if not held else route.continue_())
    page.goto(f"{live_server.url}/s/hallway/?PROLIFIC_PID={PID}&STUDY_ID=S&SESSION_ID=X")
    page.locator('button[value="yes"]').click()
    expect(page.locator("h1")).to_have_text("Instructions")
    page.locator("button.primary").click()

    p = Participant.objects.get(platform_pid=PID)
    n_train = len(p.condition.training)
    expect(page.locator(".video-loading")).to_contain_text("Loading the videos: 0 %")
    expect(page.locator('[data-action="play"]')).to_be_disabled()
    page.screenshot(path=str(OUT / "video_loading.png"), full_page=True)
    assert page.evaluate("document.body.dataset.ready") is None
    held[0].continue_()
    page.unroute("**/media/*")
    for i in range(n_train):
        expect(page.locator("h1")).to_have_text(f"Example {i + 1} of {n_train}")
        ready(page)
        expect(page.locator(".video-loading")).to_have_count(0)
        video = page.locator(".scene video")
        assert video.evaluate("(v) => [v.muted, v.controls, v.autoplay, v.src.startsWith('blob:')]") == \
            [True, False, False, True]
        assert page.locator(".scene canvas").is_hidden() and page.locator('[data-action="trail"]').is_hidden()
        assert video.evaluate("(v) => v.duration") == pytest.approx(17.0, abs=0.2)  # the folder's clock
        submit = page.locator('form[data-require-played] button[type="submit"]')
        expect(submit).to_be_disabled()  # not before the video was watched to its end
        if i == 0:
            expect(page.locator("form .hint")).to_have_text("Watch the whole video to continue.")
        if i == 0:
            page.wait_for_function("() => document.querySelector('.scene video').currentTime > 1.5")
            page.screenshot(path=str(OUT / "video_training.png"), full_page=True)
        fast(page)
        watched(page, 1)
        expect(submit).to_be_enabled()
        expect(page.locator('[data-action="play"]')).to_have_text("Replay")
        if i == n_train - 1:  # the first test's first video held back: the bar says the other three are here
            held.clear()
            page.route("**/media/*", lambda route: held.append(route) if not held else route.continue_())
        submit.click()

    n_tests = len(study.test_set)
    expect(page.locator(".video-loading")).to_contain_text("Loading the videos: 75 %")
    held[0].continue_()
    page.unroute("**/media/*")
    for j in range(n_tests):
        expect(page.locator("h1")).to_have_text(f"Question {j + 1} of {n_tests}")
        ready(page)
        assert page.locator(".option .scene video").count() == 4
        assert page.evaluate("() => [...document.querySelectorAll('video')].every((v) => !v.autoplay && v.paused)")
        fast(page)
        page.locator('[data-action="play-all"]').click()
        if j == 0:
            page.wait_for_function("() => [...document.querySelectorAll('video')].every((v) => v.currentTime > 4)")
            page.evaluate("() => document.querySelectorAll('video').forEach((v) => v.pause())")
            two_by_two_then_stacked(page, "video")
            fast(page)
            page.locator('[data-action="play-all"]').click()
        watched(page, 4)
        choose_a_and_rate_all(page)

    finish(page)
    assert not errors, errors
    p.refresh_from_db()
    assert p.completed_at and not p.excluded

    # every video the participant was shown came from an opaque name under their own link, and no page,
    # JSON answer or media URL says which environment or objective it is
    assert len(media) >= n_train + 4 * n_tests
    for url in media:
        assert MEDIA.search(url), url
    for url, body in bodies:
        assert not re.search(r"env|theta|θ", url.split("/s/hallway/")[-1].lower()), url
        assert not leaks(body, table), (url, leaks(body, table))


def test_a_failed_download_says_so_and_tries_again_and_reduced_motion_plays_nothing_unasked(hallway, live_server,
                                                                                           browser):
    study, _ = hallway
    context = browser.new_context(viewport={"width": 1280, "height": 900}, reduced_motion="reduce")
    page = context.new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.route("**/media/*", lambda route: route.abort())
    page.goto(f"{live_server.url}/s/hallway/?PROLIFIC_PID={PID}x&STUDY_ID=S&SESSION_ID=X")
    page.locator('button[value="yes"]').click()
    page.locator("button.primary").click()
    expect(page.locator(".video-loading")).to_contain_text("could not be loaded")
    page.unroute("**/media/*")
    page.get_by_role("button", name="Try again").click()
    ready(page)
    expect(page.locator(".video-loading")).to_have_count(0)
    page.wait_for_timeout(1500)
    video = page.locator(".scene video")
    assert video.evaluate("(v) => [v.paused, v.currentTime]") == [True, 0]  # reduced motion: no autoplay
    expect(page.locator("form .hint")).to_contain_text("Press Play")
    fast(page)
    page.locator('[data-action="play"]').click()
    watched(page, 1)
    expect(page.locator('form[data-require-played] button[type="submit"]')).to_be_enabled()
    assert not errors, errors


def test_the_researchers_sheet_shows_every_video_and_plays_one(hallway, staff_cookie, live_server, browser):
    study, _ = hallway
    n_cells = sum(len(c.training) for c in study.conditions.all()) + 4 * len(study.test_set)
    host = live_server.url.split("//")[1].split(":")[0]
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    context.add_cookies([{"name": "sessionid", "value": staff_cookie, "domain": host, "path": "/"}])
    page = context.new_page()
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("response", lambda r: errors.append(f"{r.status} {r.url}") if r.status >= 400 else None)
    page.goto(f"{live_server.url}/dashboard/{study.slug}/stimuli/")
    ready(page)
    videos = page.locator(".cell video")
    assert videos.count() == n_cells
    assert page.evaluate("() => [...document.querySelectorAll('.cell video')].every((v) => v.src.startsWith('blob:'))")
    fast(page)
    page.locator(".cell").first.locator('[data-action="play"]').click()
    watched(page, 1)
    assert not errors, errors
