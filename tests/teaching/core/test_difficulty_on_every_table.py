"""Graded tests a researcher can get: on every shipped table, choice tests (and on the worlds from a file,
show-the-way tests) of each difficulty are had, each test on its side of the tertiles of exact BEC sizes it
was graded by, or refused in one line that says how many environments each level has."""
from __future__ import annotations

import re

import pytest

from teaching.core.difficulty import DIFFICULTIES, describe, environment_sizes
from teaching.core.showtests import select_show_tests
from teaching.core.table import TrajectoryTable
from teaching.core.testset import TestSetError, select_test_set
from tests.teaching.domains.worlds.shipped import NAMES, shipped
from tests.teaching.domains.worlds.shipped import tiny_table as world_tiny_table

FIXTURES = {"tiny": "tiny_table", "gridworld-tiny": "gridworld_tiny_table", "gridworld": "gridworld_table",
            "demo": "demo_table"}
# the tables large enough that every level must be had, by kind of test
MUST = {("gridworld", "choose"), ("demo", "choose"), ("taxi-tiny", "show")}
COUNTS = re.compile(r"\d+ low, \d+ medium, \d+ high against every test cluster's sizes, "
                    r"\d+ low, \d+ medium, \d+ high against its own")


@pytest.fixture(scope="module", params=[*FIXTURES, *(f"{n}-tiny" for n in NAMES)])
def table(request, tmp_path_factory):
    name = request.param
    if name in FIXTURES:
        yield name, TrajectoryTable.load(request.getfixturevalue(FIXTURES[name]))
        return
    with shipped(name.removesuffix("-tiny")) as domain:
        yield name, TrajectoryTable.load(world_tiny_table(tmp_path_factory, domain))


def _select(table, kind: str, difficulty: str) -> list[dict]:
    if kind == "show":
        return select_show_tests(table, [], seed=0, difficulty=difficulty)
    return select_test_set(table, [], seed=0, difficulty=difficulty)


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_each_level_is_had_or_refused_with_the_counts_of_each(table, difficulty):
    name, table = table
    kinds = ["choose"] + (["show"] if name.removesuffix("-tiny") in NAMES else [])
    for kind in kinds:
        try:
            tests = _select(table, kind, difficulty)
        except TestSetError as exc:
            message = str(exc)
            assert (name, kind) not in MUST, message
            assert "\n" not in message and f"{difficulty} difficulty" in message
            assert COUNTS.search(message) or "whatever the difficulty" in message, message
            continue
        assert tests
        lines = describe(tests)  # what teach prints, one line a test
        assert len(lines) == len(tests) and all("standard error 0 (exact sizes)" in line for line in lines)
        for t in tests:
            q1, q2 = t["bec_tertiles"]
            size = t["bec_size"]
            assert t["difficulty"] == difficulty and t["graded"] in ("all", "cluster")
            assert size == environment_sizes(table, [list(table.env_ids).index(t["env_id"])])[0]
            # exact sizes: standard error 0, so tertiles apart at all are more than 3 standard errors apart
            assert q1 <= q2 and {"low": size > q2, "medium": q1 < size <= q2, "high": size <= q1}[difficulty]
        if (name, kind) in MUST and kind == "choose":
            assert len(tests) == len(table.domain.test_clusters)
            pooled = {tuple(t["bec_tertiles"]) for t in tests if t["graded"] == "all"}
            assert all(q1 < q2 for q1, q2 in pooled)
