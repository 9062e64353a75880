"""The study's table on the teaching leaderboard, in Chromium, below the simulated pilot: every selector's row
with each learner's rank, the study's conditions highlighted, and the section no wider than a laptop's screen.
Screenshot: test-output/dashboard_leaderboard.png."""
from __future__ import annotations

import io
from pathlib import Path

import pytest
from django.core.management import call_command

from studyapp.researcher.studies import make_study
from teaching.api import read_benchmark_board

OUT = Path(__file__).resolve().parents[2] / "test-output"

pytestmark = pytest.mark.browser


def test_the_leaderboard_beside_the_pilot_in_chromium(staff_page, live_server, demo_table, settings, tmp_path):
    settings.BENCHMARK_DIR = tmp_path / "benchmark"
    study = make_study(demo_table, "leaderboard-page")
    call_command("benchmark", "--table", str(demo_table), "--seeds", "1", "--in-process", "--no-progress",
                 stdout=io.StringIO())
    board = read_benchmark_board(settings.BENCHMARK_DIR, study.source["content_hash"])
    conditions = {c.name for c in study.conditions.all()}
    OUT.mkdir(exist_ok=True)
    page, errors = staff_page
    page.set_viewport_size({"width": 1366, "height": 900})
    assert page.goto(f"{live_server.url}/dashboard/{study.slug}/").status == 200
    section = page.locator("#leaderboard")
    assert section.locator("tbody tr").count() == len(board["rows"]) + len(board["refused"])
    assert section.locator("thead th").count() == 2 + 8 + 1 + 1  # selector, mean rank, 8 learners, accuracy, study
    highlighted = section.locator("tr.in-study")
    assert {highlighted.nth(i).get_attribute("data-selector") for i in range(highlighted.count())} == (
        conditions & {r["selector"] for r in board["rows"]})
    assert page.locator("#pilot").bounding_box()["y"] < section.bounding_box()["y"]  # below the pilot
    assert page.evaluate("document.documentElement.scrollWidth") <= 1366
    last = section.locator("thead th").last.bounding_box()  # "In this study": on screen, not scrolled out of the card
    assert last["x"] + last["width"] <= section.bounding_box()["x"] + section.bounding_box()["width"] + 1
    section.screenshot(path=str(OUT / "dashboard_leaderboard.png"))
    assert not errors, errors
