"""The whole researcher flow in Chromium, on the production stack: scripts/serve.sh (nginx,
gunicorn, a Celery worker under supervisord) against PostgreSQL and Redis (tests/load/harness.py).

A researcher logs in, builds a small real table on the worker, designs a study on it, builds the
study on the worker while its job page shows progress, previews a condition (as a participant,
never counted) and the test set's options, opens the study; a participant completes it in
another browser; the live analysis shows them; the researcher logs out.  Under CI=true a missing
PostgreSQL or Redis fails the test instead of skipping it.
"""
from __future__ import annotations

import re
import subprocess
import sys

import pytest
from playwright.sync_api import expect

from tests.load import harness
from tests.services import PG_URL, postgres_reachable, redis_reachable

USER, PASSWORD = "ada", "a-long-and-unusual-passphrase-42"
# On 24 θ one environment alone shows "braking: change lane": a study whose sequences take it has
# no test set, so the study is exact's selection and a hand-picked condition (tiny table ids).
CONDITIONS = ("exact",)
HAND_PICKED = "500, 5780"
SLUG = "flow"

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]


def create_researcher(server) -> None:
    """The account, made as a real deployment makes it (manage.py create_researcher)."""
    out = subprocess.run([sys.executable, "manage.py", "create_researcher", USER, "--password-stdin"],
                         cwd=harness.ROOT, env=server.env, input=PASSWORD + "\n", text=True, capture_output=True,
                         timeout=60)
    assert out.returncode == 0, f"create_researcher failed ({out.returncode}):\n{out.stdout}{out.stderr}"


def wait_for_job(page, timeout_ms: int = 240_000) -> None:
    """On a job page (it reloads itself while the job runs): progress shown, then success; a
    failed job fails the test with the error its page shows."""
    expect(page.locator("#job-progress")).to_be_visible()
    expect(page.locator("#job-status")).to_have_text(re.compile("succeeded|failed"), timeout=timeout_ms)
    if page.locator("#job-status").inner_text() == "failed":
        pytest.fail(f"job failed: {page.locator('#job-error').inner_text()}")


def log_in(page, base: str) -> None:
    page.goto(f"{base}/dashboard/")
    expect(page).to_have_url(re.compile(r"/login/"))
    page.fill("input[name=username]", USER)
    page.fill("input[name=password]", PASSWORD)
    page.locator("form button[type=submit], form input[type=submit]").first.click()
    expect(page).to_have_url(f"{base}/dashboard/")


def build_tiny_table(page, base: str) -> None:
    page.goto(f"{base}/precompute/design/")
    expect(page.get_by_text("No trajectory table is built")).to_be_visible()
    page.select_option("#id_preset", "tiny")
    page.get_by_role("button", name="Build table").click()
    wait_for_job(page)


def design_study(page, base: str) -> None:
    page.goto(f"{base}/precompute/design/")
    table = page.locator("#id_table option").first
    expect(table).to_contain_text("tiny: 48 environments × 24 θ")
    page.fill("#id_slug", SLUG)
    page.fill("#id_name", "Whole-flow study")
    for box in page.locator("input[name=conditions]").all():
        if box.get_attribute("value") not in CONDITIONS:
            box.uncheck()
    page.locator("summary", has_text="A hand-picked condition").click()  # a folded group, opened
    page.fill("#id_hand_picked_name", "mine")
    page.fill("#id_hand_picked_env_ids", HAND_PICKED)
    page.fill("#id_target_per_condition", "5")
    page.fill("#id_min_distance", "0.1")  # 24 θ: few options are 0.5 apart (tests/conftest.py TINY_TEST_SET)
    page.locator("summary", has_text="The consent page").click()
    page.fill("#id_contact", "ada@example.org")
    # the summary above Build says what will be built, as the researcher filled it in
    summary = page.locator("[data-design-summary]")
    expect(summary).to_contain_text("Conditions (2)")
    expect(summary).to_contain_text("exact, mine (hand-picked: 2 environments)")
    expect(summary).to_contain_text("5 per condition × 2 = 10 participants")
    page.get_by_role("button", name="Build", exact=True).click()
    wait_for_job(page)
    page.locator(f"a[href='/dashboard/{SLUG}/']").click()  # the job page links to its study
    expect(page.locator("h1")).to_have_text("Whole-flow study")
    expect(page.locator("#study-status")).to_have_text("closed")


def preview(context, page) -> None:
    """One condition as a participant sees it (a new tab, never counted), and the test set's options."""
    with context.expect_page() as opened:
        page.locator("form[action*='/preview/'] button").first.click()
    participant_view = opened.value
    expect(participant_view.locator("h1")).to_have_text("Consent to take part")
    participant_view.close()
    page.goto(page.url.rstrip("/") + "/stimuli/")
    expect(page.locator("canvas").first).to_be_visible()
    page.go_back()


def submit_and_wait(page, button) -> None:
    """Click a step's button and wait for the next step's page (another heading)."""
    before = page.locator("h1").inner_text()
    button.click()
    expect(page.locator("h1")).not_to_have_text(before)


def complete_as_participant(browser, base: str, slug: str = SLUG) -> None:
    """A participant on the open study, by mouse, with animations fast-forwarded (tests/browser/
    test_participant_flow.py drives every step by keyboard and checks each in detail)."""
    context = browser.new_context(viewport={"width": 1200, "height": 1000})
    page = context.new_page()
    page.clock.install()
    page.goto(f"{base}/s/{slug}/")
    submit_and_wait(page, page.get_by_role("button", name=re.compile("agree|consent|yes", re.I)).first)
    submit_and_wait(page, page.locator("button.primary"))
    while page.locator("h1").inner_text().startswith("Example"):
        page.wait_for_selector("body[data-ready]", state="attached")
        page.clock.run_for(6000)
        submit_and_wait(page, page.locator('form[data-require-played] button[type="submit"]'))
    while page.locator("h1").inner_text().startswith("Question"):
        page.wait_for_selector("body[data-ready]", state="attached")
        for button in page.locator('[data-action="play"]').all():
            button.click()
        page.clock.run_for(6000)
        page.locator('input[name="choice"][value="A"]').check(force=True)
        for group in page.locator(".rating").all():
            group.locator("input").nth(3).check(force=True)
        submit_and_wait(page, page.locator('#test-form button[type="submit"]'))
    for name in ("merge", "forward"):  # the attention check: the two goals the study showed
        page.locator(f'input[name="goals"][value="{name}"]').check()
    submit_and_wait(page, page.get_by_role("button", name="Continue"))
    page.fill("input[name=age]", "34")
    page.locator('input[name="gender"]').first.check()
    submit_and_wait(page, page.get_by_role("button", name="Finish"))
    expect(page.locator("body")).to_contain_text(re.compile("Thank you", re.I))
    context.close()


def test_the_whole_researcher_flow(tmp_path, require_service, demo_table, browser):
    require_service(postgres_reachable(), f"PostgreSQL at {PG_URL} is unreachable")
    require_service(redis_reachable(harness.REDIS_URL), f"Redis at {harness.REDIS_URL} is unreachable")
    out = harness.ROOT / "test-output"
    out.mkdir(exist_ok=True)
    with harness.Server(tmp_path, workers=harness.FEW_WORKERS, demo_table=demo_table) as server:
        create_researcher(server)
        base = server.base_url
        context = browser.new_context(viewport={"width": 1200, "height": 1000})
        page = context.new_page()
        errors = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))

        log_in(page, base)
        build_tiny_table(page, base)
        design_study(page, base)
        preview(context, page)
        page.get_by_role("button", name="Open study").click()
        expect(page.locator("#study-status")).to_have_text("open")

        complete_as_participant(browser, base)

        page.goto(f"{base}/dashboard/{SLUG}/analysis/")
        expect(page.locator("body")).to_contain_text("1 participant")
        page.screenshot(path=str(out / "researcher_flow_analysis.png"), full_page=True)
        page.get_by_role("button", name="Log out").click()
        page.goto(f"{base}/dashboard/")
        expect(page).to_have_url(re.compile(r"/login/"))
        assert not errors, errors
