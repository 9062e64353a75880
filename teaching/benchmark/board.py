"""One table's leaderboard as data: what the page (leaderboard.py) and the researcher's dashboard both show.

    <out>/tables/<content hash>.json   the board of each table a benchmark run summarised (BOARD_FORMAT)

A board holds the table's identity and ceiling, its held-out tests, and a row per selector in the order of its
mean rank over the learners: for each learner its rank (standings.py) and mean final P(θ*), then the examples to
criterion, the held-out tests' measures and the selection's cost; selectors that refused the table apart.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core.conditions import SelectionContext
from ..core.learners import make_model, p_curve
from .heldout import HeldOut, held_out, pool_table
from .run import write_atomically
from .standings import finals_by_seed, rank
from .summary import Row, mismatch, summarise

BOARD_FORMAT = 1
# What a reader needs of a board, by type: a file lacking one is refused in a line, never half-shown.
FIELDS = {"name": str, "learners": list, "seeds": int, "ceiling": float, "tests": dict, "rows": list,
          "refused": list, "mismatch": dict}


def table_name(path, table) -> str:
    """The name a table goes by: its preset, else its folder's name."""
    return str(table.meta.get("preset") or Path(path).name)


def ceiling(pool) -> float:
    """The exact learner's P(θ*) after every environment a selector may show of the selectors' table `pool`
    (heldout.pool_table): no sequence can teach it more.  Below 1 where some objectives behave as θ* does on every
    such environment."""
    ctx = SelectionContext(pool, seed=0)
    return float(p_curve(make_model("exact"), ctx.dist, np.flatnonzero(ctx.eligible))[-1])


def final_mean(rows: list[Row], selector: str, field: str) -> float | None:
    """The mean over learners of a selector's `field` curve's last value (None: the table has no such tests)."""
    ends = [getattr(r, field)[-1] for r in rows if r.selector == selector and not r.error and getattr(r, field)]
    return float(np.mean(ends)) if ends else None


def criterion(results: list[dict], selector: str) -> dict:
    """{"mean": mean examples to criterion over every learner and seed that reaches it (None: none does),
    "reached": how many do, "of": how many there are}."""
    mine = [r for r in results if r["cell"]["selector"] == selector and "error" not in r]
    reached = [r["examples_to_criterion"] for r in mine if r["examples_to_criterion"] is not None]
    return {"mean": float(np.mean(reached)) if reached else None, "reached": len(reached), "of": len(mine)}


def tests_of(held: HeldOut) -> dict:
    return {"choose": [int(t["env_id"]) for t in held.choose], "show": [int(t["env_id"]) for t in held.show]}


def last_run(out, content_hash: str) -> dict | None:
    """The record run.timed left of the last run that computed cells of the table (None: none, or unreadable)."""
    try:
        return json.loads((Path(out) / "runs" / f"{content_hash}.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def board(path, table, results: list[dict], costs: dict[str, float], out=None) -> tuple[dict, list[Row]]:
    """(the board of one table's results, the summary rows it was made from: the figures' curves); `out`: the
    results folder, whose record of the last run is quoted."""
    rows = summarise(results, costs)
    learners = list(dict.fromkeys(r.learner for r in rows))
    standings = {u: rank(finals_by_seed(results, u)) for u in learners}
    place = {(s.selector, u): s for u in learners for s in standings[u]}
    selectors = list(dict.fromkeys(r.selector for r in rows))
    ranked = [s for s in selectors if all((s, u) in place for u in learners)]
    mean_rank = {s: float(np.mean([place[(s, u)].rank for u in learners])) for s in ranked}
    cost = {}
    for r in rows:
        if r.selection_cost is not None:
            cost.setdefault(r.selector, r.selection_cost)
    held = held_out(table)
    built, columns, matrix = mismatch(rows)
    values = {}
    for r in results:
        if "error" not in r:
            values.setdefault(r["cell"]["learner"], r.get("learner_value"))
    fixed = next((r["cell"].get("hyper") or {} for r in results), {})
    out = {
        "format": BOARD_FORMAT, "name": table_name(path, table), "path": str(path), "domain": table.domain.name,
        "content_hash": table.meta["content_hash"], "n_envs": table.n_envs, "n_thetas": table.n_thetas,
        "seeds": len({r["cell"]["seed"] for r in results}), "learners": learners, "cells": len(results),
        "values": {u: values.get(u) for u in learners}, "hyper": fixed,
        "run": None if out is None else last_run(out, table.meta["content_hash"]),
        "ceiling": ceiling(pool_table(table, held.pool)), "tests": tests_of(held),
        "rows": [{"selector": s, "mean_rank": mean_rank[s],
                  "cells": [{"learner": u, "rank": place[(s, u)].rank, "tied": place[(s, u)].tied,
                             "mean": place[(s, u)].mean} for u in learners],
                  "criterion": criterion(results, s), "mean_final": final_mean(rows, s, "curve"),
                  "accuracy": final_mean(rows, s, "accuracy"), "regret": final_mean(rows, s, "regret"),
                  "selection_seconds": cost.get(s)}
                 for s in sorted(ranked, key=lambda s: (mean_rank[s], s))],
        "refused": [{"selector": r.selector, "error": r.error} for r in rows if r.error and r.learner == learners[0]],
        "mismatch": {"built": built, "learners": columns, "matrix": [[None if np.isnan(v) else float(v) for v in row]
                                                                     for row in matrix]},
    }
    return out, rows


def board_path(out, content_hash: str) -> Path:
    return Path(out) / "tables" / f"{content_hash}.json"


def write_board(out, data: dict) -> Path:
    """The board in `out`'s tables/, whole or not at all."""
    path = board_path(out, data["content_hash"])
    write_atomically(path, data)
    return path


def read_board(out, content_hash: str) -> dict | None:
    """The board of the table `content_hash` in results folder `out`: None where there is none; ValueError (one
    line naming the file) where the file cannot be read as a board."""
    path = board_path(out, content_hash)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not a benchmark board ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != BOARD_FORMAT or data.get("content_hash") != content_hash:
        raise ValueError(f"{path}: not a benchmark board of format {BOARD_FORMAT} for table {content_hash[:16]}; "
                         "run the benchmark on the table again")
    missing = [k for k, kind in FIELDS.items() if not isinstance(data.get(k), kind)]
    if missing:
        raise ValueError(f"{path}: not a benchmark board: {', '.join(missing)} missing or malformed; run the "
                         "benchmark on the table again")
    return data
