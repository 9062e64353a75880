"""Fixtures the browser tests share."""
from __future__ import annotations

import asyncio
import os

import pytest
from playwright.sync_api import expect, sync_playwright

from studyapp.researcher.studies import build_study, demo_spec
from teaching.core.table import TrajectoryTable
from tests.studyapp.test_stimuli import real_spec

# A guard against a page that never comes, not a measure of speed: Playwright's 5 s default for
# expect() was missed on a machine running three test processes on two cores (a page under load).
expect.set_options(timeout=30_000)

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")


@pytest.fixture(scope="session")
def _chromium():
    """Debian's Chromium, launched once per pytest process and shared by its browser tests, with Playwright's
    event loop: yields (browser, loop).  Starting Playwright's driver and Chromium costs about 1.2 s of CPU
    where a fresh context costs 0.3, so a launch per test cost the suite about a minute of CPU."""
    assert os.path.exists(CHROMIUM), f"Chromium not installed at {CHROMIUM} (apt-get install chromium)"
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True)
        loop = asyncio.get_running_loop()  # Playwright's, which it marks running in this thread between calls
        asyncio._set_running_loop(None)
        yield browser, loop
        asyncio._set_running_loop(loop)  # Playwright shuts down from where it left off


@pytest.fixture
def browser(_chromium, monkeypatch):
    """The process's Chromium for one test; the contexts and pages the test opened are closed after it.

    Playwright marks its event loop as running in this thread for as long as it lives, and its loop needs
    the mark when it resumes.  So the mark is set for the test (with Django's async-safety check off: the
    test's ORM calls run beside that loop, as they did beside a Playwright of its own) and cleared after it,
    so that the tests this process runs next see no event loop and keep Django's check."""
    chromium, loop = _chromium
    monkeypatch.setenv("DJANGO_ALLOW_ASYNC_UNSAFE", "true")
    asyncio._set_running_loop(loop)
    try:
        yield chromium
    finally:
        for context in chromium.contexts:
            context.close()
        asyncio._set_running_loop(None)


@pytest.fixture
def staff_cookie(transactional_db, client):
    """A researcher's session cookie, for a browser context (ctx.add_cookies)."""
    from django.contrib.auth.models import User  # noqa: PLC0415

    user = User.objects.create_user("researcher", password="pw-stimuli-1", is_staff=True)
    client.force_login(user)
    return client.cookies["sessionid"].value


@pytest.fixture
def studies(transactional_db, demo_table, tiny_table, monkeypatch):
    """The demo study on the session's demo table, and a study with real stimuli on the tiny table:
    every scene the scene tests draw."""
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    demo = build_study(demo_spec())
    real = build_study(real_spec(TrajectoryTable.load(tiny_table), tiny_table))
    return [demo, real]


@pytest.fixture
def staff_page(staff_cookie, live_server, browser):
    """A researcher's page in Debian's Chromium (1280 × 900, logged in) for the live server, and the list of
    JavaScript errors it meets: yields (page, errors)."""
    host = live_server.url.split("//")[1].split(":")[0]
    ctx = browser.new_context(viewport={"width": 1280, "height": 900})
    ctx.add_cookies([{"name": "sessionid", "value": staff_cookie, "domain": host, "path": "/"}])
    page = ctx.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    yield page, errors
