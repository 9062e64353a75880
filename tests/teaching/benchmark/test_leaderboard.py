"""The leaderboard (teaching/benchmark/standings.py, leaderboard.py): Holm's correction and the paired test by
hand, ties ranked as ties, and the page generated from a real run (every selector ranked for every learner, its
figures written, the same bytes when generated again, a selector registered later on it)."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from teaching.benchmark.board import board, read_board, write_board
from teaching.benchmark.cells import plan_cells
from teaching.benchmark.leaderboard import findings, findings_on_tests, write_leaderboard
from teaching.benchmark.run import run_cells
from teaching.benchmark.standings import EQUAL, holm, paired_p, rank, rank_label
from teaching.benchmark.summary import read_costs
from teaching.core import selectors
from teaching.core.learners import LEARNER_NAMES
from teaching.core.selection import evaluated
from teaching.core.selectors import Selector, selector_names
from teaching.core.table import TrajectoryTable


def test_holms_step_down_by_hand():
    """p sorted: .005, .01, .03, .04 times 4, 3, 2, 1: .02, .03, .06, .04, the last raised to .06 (monotone)."""
    assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert holm([]) == []


def test_the_paired_test_by_hand_and_its_two_certain_cases():
    """d = (1, 1, 1.5): mean 7/6, s = √(1/12), t = (7/6) / (s / √3) = 7, 2 degrees of freedom: p = 2 (1 - F(7)) =
    1 - 7/√51 = 0.019804 (Student's t with 2 df: F(t) = 1/2 + t / (2 √(2 + t²)))."""
    assert paired_p(np.array([1, 2, 3.5]), np.array([0, 1, 2.0])) == pytest.approx(1 - 7 / np.sqrt(51), rel=1e-9)
    assert paired_p(np.array([0.3, 0.9]), np.array([0.3, 0.9])) == 1.0  # the same teaching
    assert paired_p(np.array([0.3, 0.9]), np.array([0.3 + EQUAL / 2, 0.9])) == 1.0  # closer than the page shows
    assert paired_p(np.array([0.5, 0.9]), np.array([0.25, 0.65])) == 0.0  # the same difference under every seed
    assert paired_p(np.array([0.5]), np.array([0.25])) == 1.0  # one seed tells nothing


def test_ties_are_ranked_as_ties_and_a_certain_gap_opens_a_new_rank():
    """a and b teach alike (=1); c is .25 below them under every seed (3); d's seeds scatter around c's level and
    cannot be told from c (=3); e is 0 under every seed (5)."""
    seeds = range(4)
    scores = {"a": dict.fromkeys(seeds, 1.0), "b": dict.fromkeys(seeds, 1.0), "c": dict.fromkeys(seeds, 0.75),
              "d": dict(zip(seeds, [0.9, 0.5, 0.8, 0.6], strict=True)), "e": dict.fromkeys(seeds, 0.0)}
    standings = rank(scores)
    assert [(s.selector, rank_label(s)) for s in standings] == [("a", "=1"), ("b", "=1"), ("c", "=3"), ("d", "=3"),
                                                                ("e", "5")]
    assert standings[3].mean == pytest.approx(0.7) and standings[0].seeds == 4


def hand_board(name: str, rows: dict[str, list[tuple[int, bool]]], built: list[str], matrix, ceiling: float,
               measures: dict[str, tuple] | None = None) -> dict:
    """A board with the fields the findings read: rows {selector: [(rank, tied) per learner]}; measures {selector:
    (mean final P(θ*), test accuracy, show regret)}."""
    learners = ["exact", "det-reward"]
    measures = measures or {}
    return {"name": name, "learners": learners, "ceiling": ceiling,
            "mismatch": {"built": built, "learners": learners, "matrix": matrix},
            "rows": [{"selector": s, "cells": [{"learner": u, "rank": r, "tied": t} for u, (r, t) in
                                               zip(learners, ranks, strict=True)],
                      "mean_final": measures.get(s, (None,) * 3)[0], "accuracy": measures.get(s, (None,) * 3)[1],
                      "regret": measures.get(s, (None,) * 3)[2]} for s, ranks in rows.items()]}


def test_the_findings_count_wins_and_the_mismatch_diagonal():
    """exact: first alone for the exact learner, tied first with det-reward for the det-reward learner; scot second;
    the mismatch matrix's rows built for exact and det-reward."""
    board = hand_board("t", {"exact": [(1, False), (1, True)], "det-reward": [(2, False), (1, True)],
                             "scot": [(3, False), (3, False)]},
                       ["exact", "det-reward"], [[1.0, 0.9], [0.5, 0.9]], 0.125)
    text = "\n".join(findings([board]))
    assert "exact in 2 (1 alone)" in text
    assert "For the **det-reward** learner, first (alone or tied) on 1 of 1 tables: det-reward, exact." in text
    # columns: exact's own 1.0 is its best (+0.5 over det-reward's); det-reward's own .9 ties exact's (+0.0)
    assert "in 2 of 2 (table, learner) columns" in text and "+0.250 above" in text
    assert "On t (0.125), some objectives behave as θ\\* does" in text


def test_the_page_ranks_every_selector_for_every_learner_and_regenerates_the_same(monkeypatch,
                                                                                   gridworld_tiny_table, tmp_path):
    monkeypatch.setattr(selectors, "_REGISTRY", dict(selectors._REGISTRY))
    def first_two(ctx):
        return evaluated([int(e) for e in np.flatnonzero(ctx.eligible)[:2]], ctx.fitted("exact")[0], ctx.dist)

    selectors.register_selector(Selector("toy-first-two", first_two))
    table = TrajectoryTable.load(gridworld_tiny_table)
    out = tmp_path / "results"
    results = run_cells(table, plan_cells(table.meta["content_hash"], seeds=3), out)
    made = board(str(gridworld_tiny_table), table, results, read_costs(out))
    page = write_leaderboard(tmp_path / "docs" / "leaderboard.md", [made])
    text = page.read_text()
    rows = [line for line in text.splitlines() if line.startswith("| ") and not line.startswith("| selector")]
    assert sorted(r.split(" | ")[0][2:] for r in rows) == sorted(selector_names())  # the toy's row too
    for row in rows:
        cells = row.split(" | ")[2:2 + len(LEARNER_NAMES)]
        assert all(re.fullmatch(r"(\*\*)?=?\d+(\*\*)? [01]\.\d{3}", c) for c in cells), row
    figures = tmp_path / "docs" / "figures" / "leaderboard"
    for name in ("gridworld-tiny_curves.png", "gridworld-tiny_mismatch.png"):
        assert f"](figures/leaderboard/{name})" in text
        assert (figures / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    first = {p.name: p.read_bytes() for p in [page, *figures.iterdir()]}
    again = run_cells(table, plan_cells(table.meta["content_hash"], seeds=3), out)
    write_leaderboard(page, [board(str(gridworld_tiny_table), table, again, read_costs(out))])
    assert {p.name: p.read_bytes() for p in [page, *figures.iterdir()]} == first
    write_board(out, made[0])
    assert read_board(out, table.meta["content_hash"]) == json.loads(json.dumps(made[0]))


def test_the_test_findings_name_the_best_and_the_rank_agreement_by_hand():
    """Accuracy in the reverse order of P(θ*): ρ = -1; regret rising with P(θ*) (lower is better) is the reverse
    order too; a table without tests of a kind says nothing of them."""
    ranks = {s: [(1, False), (1, False)] for s in "abc"}
    t = hand_board("t", ranks, [], [], 1.0, {"a": (0.9, 0.2, 0.5), "b": (0.5, 0.6, 0.3), "c": (0.1, 0.7, 0.1)})
    u = hand_board("u", ranks, [], [], 1.0, {"a": (0.9, None, None), "b": (0.5, None, None), "c": (0.1, None, None)})
    text = "\n".join(findings_on_tests([t, u]))
    assert "t: the best test accuracy, 0.700, by c; ρ = -1.00." in text
    assert "t: the best show regret, 0.100, by c; ρ = -1.00." in text
    assert "u:" not in text and findings_on_tests([u]) == []


def test_a_board_file_that_is_not_one_says_so_in_a_line(tmp_path):
    assert read_board(tmp_path, "ab" * 16) is None
    path = tmp_path / "tables" / f"{'ab' * 16}.json"
    path.parent.mkdir()
    for text in ("{not json", json.dumps({"format": 99, "content_hash": "ab" * 16}), "[]",
                 json.dumps({"format": 1, "content_hash": "ab" * 16, "rows": "not a list"})):
        path.write_text(text)
        with pytest.raises(ValueError, match=r"tables/abab.*\.json: not a benchmark board"):
            read_board(tmp_path, "ab" * 16)
