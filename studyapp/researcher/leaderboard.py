"""A study's table on the teaching leaderboard: what the dashboard shows next to the simulated pilot, so that a
researcher sees how every selector teaches every simulated learner on this table before picking conditions.

The board is the one `manage.py benchmark` wrote for the study's table (by its content hash) to
settings.BENCHMARK_DIR (teaching/benchmark/board.py); the page only reads it.  The rows of selectors this study
runs as conditions are marked with the conditions' names.
"""
from __future__ import annotations

import shlex

from django.conf import settings

from teaching.api import read_benchmark_board

from ..models import Study

# The held-out tests' columns: (a row's field, the board's test kind that gives it, the column's heading).
MEASURES = (("accuracy", "choose", "test accuracy"), ("regret", "show", "show regret"))


def study_selectors(study: Study) -> dict[str, list[str]]:
    """selector -> the names of the study's conditions that run it (a designer-built study records each
    condition's selector; otherwise a condition is named after its selector, as the paper's are)."""
    recorded = (study.source or {}).get("selectors") or {}
    found: dict[str, list[str]] = {}
    for condition in study.conditions.order_by("position", "name"):
        selector = (recorded.get(condition.name) or {}).get("selector", condition.name)
        found.setdefault(selector, []).append(condition.name)
    return found


def leaderboard_context(study: Study) -> dict:
    """{"leaderboard": the board laid out for the page, or None; "leaderboard_problem": why it cannot be read ("" if
    it can, or there is none); "leaderboard_command": the command that makes it}."""
    source = study.source or {}
    content_hash, table = source.get("content_hash"), source.get("table")
    command = f"python manage.py benchmark --table {shlex.quote(str(table))}" if table else ""
    out = {"leaderboard": None, "leaderboard_problem": "", "leaderboard_command": command,
           "leaderboard_dir": str(settings.BENCHMARK_DIR)}
    if not content_hash:
        return out
    try:
        board = read_benchmark_board(settings.BENCHMARK_DIR, content_hash)
    except ValueError as exc:
        return {**out, "leaderboard_problem": str(exc)}
    if board is None:
        return out
    mine = study_selectors(study)
    try:
        measures = [(field, label) for field, kind, label in MEASURES if board["tests"][kind]]
        rows = [{**row, "conditions": mine.get(row["selector"], []),
                 "measures": [row[field] for field, _ in measures]} for row in board["rows"]]
    except (KeyError, TypeError) as exc:  # a row or test list not as the benchmark writes it
        return {**out, "leaderboard_problem": f"the benchmark's board of this table lacks {exc}: run it again"}
    return {**out, "leaderboard": {**board, "rows": rows, "measures": [label for _, label in measures],
                                   "low_ceiling": board["ceiling"] < 0.5}}
