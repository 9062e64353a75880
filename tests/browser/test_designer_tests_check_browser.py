"""In Debian's Chromium: the designer shows, beside the test fields, how many environments of the chosen
table could hold each test, per difficulty; a difficulty no environment can hold is said there at once and,
on "Build", under its field, with no job started.  Screenshot: test-output/designer_test_counts.png."""
from __future__ import annotations

import pytest
from playwright.sync_api import expect

from precompute.models import Job
from tests.browser.grid_pages import OUT

pytestmark = [pytest.mark.browser]


@pytest.fixture
def tiny_listed(settings, tiny_table):
    settings.TABLES_DIR = tiny_table.parent
    return tiny_table


def test_the_counts_beside_the_tests_and_a_refused_difficulty(tiny_listed, live_server, staff_page):
    page, errors = staff_page
    page.goto(f"{live_server.url}/precompute/design/")
    page.select_option("#id_table", str(tiny_listed))
    page.fill("#id_min_distance", "0.1")
    page.locator("#id_min_distance").dispatch_event("change")
    counts = page.locator("[data-test-supply] table")
    expect(counts.locator("tbody tr")).to_have_count(6, timeout=30_000)  # one row per test cluster
    expect(counts.locator("tbody tr").first).to_contain_text("merging: ahead")
    page.select_option("#id_test_difficulty", "low")
    said = page.locator("[data-test-supply] p.error")
    expect(said).to_contain_text("No environment of this table can hold a test of low difficulty")
    expect(said).to_contain_text("choose high, or none")
    OUT.mkdir(exist_ok=True)
    page.locator("#design-tests").screenshot(path=str(OUT / "designer_test_counts.png"))

    page.fill("#id_slug", "refused-low")
    page.get_by_role("button", name="Build", exact=True).click()
    expect(page.locator("#design-tests")).to_contain_text(
        "No environment of this table can hold a test of low difficulty")
    expect(page.locator(".design-nav")).to_contain_text("Tests (to correct)")
    assert not Job.objects.exists() and errors == []
