"""The study's table on the teaching leaderboard, beside the pilot on its dashboard
(studyapp/researcher/leaderboard.py): the command that makes it when there is none, the board `manage.py benchmark`
wrote when there is (its ranks and means, the study's conditions marked), and a line, not a 500, for a file that
is not a board."""
from __future__ import annotations

import io
import json
import re

import pytest
from django.core.management import call_command
from django.urls import reverse

from teaching.api import read_benchmark_board
from tests.conftest import PAPER_SEQUENCES


@pytest.fixture
def paper_named_study(make_study):
    """Conditions named after the selectors they are: exact, random and coverage-approx*."""
    return make_study(slug="named", sequences={k: PAPER_SEQUENCES[k] for k in ("exact", "random", "coverage-approx*")})


def page(client, study) -> str:
    response = client.get(reverse("dashboard_study", args=[study.slug]))
    assert response.status_code == 200
    return response.content.decode()


def test_without_a_benchmark_the_dashboard_gives_the_command_that_makes_it(staff_client, study, settings, tmp_path):
    settings.BENCHMARK_DIR = tmp_path / "benchmark"
    html = page(staff_client, study)
    assert 'id="no-leaderboard"' in html and str(settings.BENCHMARK_DIR) in html
    assert f"python manage.py benchmark --table {study.source['table']}" in html


def test_the_dashboard_shows_the_board_of_its_table_with_its_conditions_marked(staff_client, paper_named_study,
                                                                              settings, tmp_path, tiny_table):
    settings.BENCHMARK_DIR = tmp_path / "benchmark"
    call_command("benchmark", "--table", str(tiny_table), "--seeds", "1", "--in-process", "--no-progress",
                 stdout=io.StringIO())
    board = read_benchmark_board(settings.BENCHMARK_DIR, paper_named_study.source["content_hash"])
    html = page(staff_client, paper_named_study)
    table = html[html.index('id="leaderboard-table"'):html.index("</table>", html.index('id="leaderboard-table"'))]
    shown = re.findall(r'<tr data-selector="([^"]+)"', table)
    assert shown == [r["selector"] for r in board["rows"]] + [r["selector"] for r in board["refused"]]
    assert len(shown) >= 15 and "<th>test accuracy</th>" in table  # the tiny table holds choice tests
    for row in board["rows"]:
        found = table[table.index(f'<tr data-selector="{row["selector"]}"'):]
        found = found[:found.index("</tr>")]
        marked = 'class="in-study"' in found
        assert marked == (row["selector"] in ("exact", "random", "coverage-approx*")), row["selector"]
        first = row["cells"][0]
        label = ("=" if first["tied"] else "") + str(first["rank"])
        assert re.search(rf"{re.escape(label)}(</strong>)?\s*<small>{first['mean']:.3f}</small>", found), found
        if marked:
            assert f'<td class="conditions">{row["selector"]}</td>' in found  # its condition, named after it


def test_a_file_that_is_not_a_board_is_one_line_on_the_dashboard(staff_client, study, settings, tmp_path):
    settings.BENCHMARK_DIR = tmp_path / "benchmark"
    path = settings.BENCHMARK_DIR / "tables" / f"{study.source['content_hash']}.json"
    path.parent.mkdir(parents=True)
    for board in ({"format": 1, "content_hash": "someone else's"},
                  {"format": 1, "content_hash": study.source["content_hash"], "name": "t", "learners": ["exact"],
                   "seeds": 1, "ceiling": 1.0, "tests": {}, "rows": [{"selector": "scot"}], "refused": [],
                   "mismatch": {}}):
        path.write_text(json.dumps(board))
        html = page(staff_client, study)
        assert 'id="leaderboard-problem"' in html and ("not a benchmark board" in html or "run it again" in html)
