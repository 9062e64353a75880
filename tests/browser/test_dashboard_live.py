"""The researcher dashboard in Chromium: staff login, live progress refresh, preview, open/close.

A participant arrives while the dashboard is open; the condition table must pick the arrival
up by itself (the fragment is re-fetched every few seconds, on Playwright's fake clock here).
"""
from __future__ import annotations

from pathlib import Path

import pytest
from django.db import connections
from playwright.sync_api import expect

from studyapp.models import Participant
from studyapp.participant.assignment import assign

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def test_dashboard_live_progress(make_study, transactional_db, live_server, django_user_model, browser):
    study = make_study("live")
    django_user_model.objects.create_user("res", password="pw-dash-123", is_staff=True)
    OUT.mkdir(exist_ok=True)
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.clock.install()
    page.goto(f"{live_server.url}/dashboard/{study.slug}/")
    assert "/login/" in page.url and "/admin/" not in page.url  # the researcher login first
    page.fill("#id_username", "res")
    page.fill("#id_password", "pw-dash-123")
    page.click("input[type=submit]")
    expect(page.locator("h1")).to_have_text(study.name)
    started = page.locator("tfoot td").nth(2)
    expect(started).to_have_text("0")
    page.wait_for_selector("body[data-ready]", state="attached")  # the refresh timer is set

    assign(study, "prolific", "arrives-while-watching")
    connections.close_all()
    page.clock.run_for(6000)  # one refresh period
    expect(started).to_have_text("1")
    expect(page.locator(".activity")).to_contain_text("No answers yet")
    page.screenshot(path=str(OUT / "dashboard.png"), full_page=True)

    # preview a condition in a new tab: a participant that is not counted
    with page.context.expect_page() as new_tab:
        page.locator('tr[data-condition="beta"] button').click()
    preview = new_tab.value
    expect(preview.locator(".badge")).to_have_text("Staff preview: not counted")
    page.clock.run_for(6000)
    expect(started).to_have_text("1")

    page.get_by_role("button", name="Close study").click()
    expect(page.locator("#study-status")).to_have_text("closed")
    connections.close_all()
    assert Participant.objects.filter(platform="preview").count() == 1
    study.refresh_from_db()
    assert not study.is_open
