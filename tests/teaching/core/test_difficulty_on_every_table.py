"""Graded tests a researcher can get: on every shipped table, choice tests (and on the worlds from a file,
show-the-way tests) of each difficulty are had, each test on its side of the tertiles of exact BEC sizes it
was graded by, or refused in one line that says how many environments each level has; and the counts the
study designer shows before Build (teaching.core.testsupply) say which of them the build can draw."""
from __future__ import annotations

import json
import re

import pytest

from teaching.core.conditions import build_sequences
from teaching.core.difficulty import DIFFICULTIES, describe, environment_sizes
from teaching.core.showtests import select_show_tests
from teaching.core.table import TrajectoryTable
from teaching.core.testset import TestSetError, select_test_set
from teaching.core.testsupply import ANY, clusters_without_a_test, supply_of_tests
from tests.teaching.domains.worlds.shipped import NAMES, shipped, teach_show
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


def _select(table, kind: str, difficulty: str | None, training=()) -> list[dict]:
    if kind == "show":
        return select_show_tests(table, list(training), seed=0, difficulty=difficulty)
    return select_test_set(table, list(training), seed=0, difficulty=difficulty)


def _kinds(name: str) -> list[str]:
    return ["choose"] + (["show"] if name.removesuffix("-tiny") in NAMES else [])


_SUPPLIES = {}  # (table name, kind) -> its TestSupply: counting a large table takes seconds, once


def _supply(name: str, table, kind: str):
    if (name, kind) not in _SUPPLIES:
        _SUPPLIES[name, kind] = supply_of_tests(table, kind)
    return _SUPPLIES[name, kind]


@pytest.mark.parametrize("difficulty", DIFFICULTIES)
def test_each_level_is_had_or_refused_with_the_counts_of_each(table, difficulty):
    name, table = table
    for kind in _kinds(name):
        supply = _supply(name, table, kind)
        try:
            tests = _select(table, kind, difficulty)
        except TestSetError as exc:
            message = str(exc)
            assert not supply.feasible(difficulty), (name, kind, message)  # the designer would have let it through
            assert f"{difficulty} difficulty" in supply.problem(difficulty) and "\n" not in supply.problem(difficulty)
            assert (name, kind) not in MUST, message
            assert "\n" not in message and f"{difficulty} difficulty" in message
            assert COUNTS.search(message) or "whatever the difficulty" in message, message
            continue
        assert tests
        assert supply.feasible(difficulty) and supply.problem(difficulty) == "", (name, kind, supply.describe())
        # a test is drawn only from environments the designer counted at that level for its cluster
        drawn = {t["cluster"] for t in tests}
        counts = dict(zip(table.domain.test_clusters, supply.counts(difficulty), strict=True))
        assert all(counts[c] >= 1 for c in drawn)
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


def test_the_designers_counts_say_whether_an_ungraded_test_set_is_built(table):
    """Feasible ⇔ built with no difficulty, every kind, every shipped table; a refusal names the clusters."""
    name, table = table
    for kind in _kinds(name):
        supply = _supply(name, table, kind)
        try:
            _select(table, kind, None)
            built = True
        except TestSetError:
            built = False
        assert supply.feasible(ANY) == built, (name, kind, supply.describe())
        if not built:
            problem = supply.problem(ANY)
            empty = [n for n, k in zip(supply.clusters, supply.hosts, strict=True) if not k]
            assert "\n" not in problem and all(f"'{n}'" in problem for n in empty if kind == "choose"), problem
        assert all(n <= hosts for d in DIFFICULTIES  # a level's pool is among the hosts
                   for n, hosts in zip(supply.counts(d), supply.hosts, strict=True))
        assert [n for n, k in zip(supply.clusters, supply.hosts, strict=True) if not k] == \
            clusters_without_a_test(table, kind)


# the shipped tables that have a teach output in every run (their conditions' training), by the table's name
TAUGHT = {"demo": "demo_teach", "gridworld": "gridworld_teach"}


def test_after_training_the_counts_still_say_what_the_build_does(table, request, tmp_path_factory):
    """The build draws its tests outside every condition's training: counted with that training, feasible ⇔
    built at every level; and where the designer (counting before training) refuses, the build fails too."""
    name, table = table
    if name in TAUGHT:
        sequences = json.loads((request.getfixturevalue(TAUGHT[name]) / "sequences.json").read_text())
        kinds = ["choose"]
    elif name.removesuffix("-tiny") in NAMES:
        with shipped(name.removesuffix("-tiny")) as domain:
            _, out = teach_show(tmp_path_factory, domain)
        sequences = json.loads((out / "sequences.json").read_text())
        kinds = ["show"]
    else:  # a tiny table: its conditions selected here (a second or two)
        sequences = {"conditions": {k: {"env_ids": ids} for k, ids in build_sequences(table, seed=0).items()}}
        kinds = ["choose"]
    training = [c["env_ids"] for c in sequences["conditions"].values()]
    for kind in kinds:
        designer, after = _supply(name, table, kind), supply_of_tests(table, kind, training)
        for difficulty in (ANY, *DIFFICULTIES):
            try:
                _select(table, kind, None if difficulty == ANY else difficulty, training)
                built = True
            except TestSetError:
                built = False
            assert after.feasible(difficulty) == built, (name, kind, difficulty, after.describe())
            assert built <= designer.feasible(difficulty), (name, kind, difficulty)  # a refusal is never wrong
