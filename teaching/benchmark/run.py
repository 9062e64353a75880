"""Computing a table's benchmark cells into a results folder, resumably.

    <out>/cells/<key>.json   each cell's result (its cell, the environments shown, P(θ*) after each, the
                             examples to criterion, the held-out tests' accuracy and show regret after each
                             (heldout.py; null where the table has none of a kind), or the selector's one-line
                             refusal): byte-identical on rerun
    <out>/costs/<key>.json   the seconds its selection took (a measurement, so kept apart from the results)

A result is written to a hidden file and renamed into place, so a run killed at any moment leaves whole results
only, and the next run computes exactly the cells that are missing.  One selection serves every learner of the
same (selector, parameters, seed).  Every learner model is fitted (its τ / λ by the paper's rule) once per table,
before any selection is timed, so a selection's seconds are its own search alone, whichever runs first.
"""
from __future__ import annotations

import json
import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..core.conditions import SelectionContext
from ..core.learners import LEARNER_NAMES, Distances, has_hyperparameter
from ..core.selectors import get_selector
from ..core.table import TrajectoryTable
from .cells import CRITERION, Cell
from .heldout import Tests, held_out, log_posteriors, pool_table


def result_path(out: Path, cell: Cell) -> Path:
    return Path(out) / "cells" / f"{cell.key}.json"


def write_atomically(path: Path, data: dict) -> None:
    """`data` as JSON at `path`, whole or not at all."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(data, f, sort_keys=True, indent=1)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def examples_to_criterion(curve: list[float], criterion: float = CRITERION) -> int | None:
    """The number of examples after which P(θ*) first reaches `criterion`; None if it never does."""
    reached = np.flatnonzero(np.asarray(curve) >= criterion)
    return int(reached[0]) + 1 if reached.size else None


class Runner:
    """The cells of one table: its held-out tests drawn once (heldout.py), the selectors' table (the rest) and its
    distances once, each learner model fitted once on it, each selection once."""

    def __init__(self, table, hyper: tuple[tuple[str, float], ...] = ()):
        """hyper: a cell's fixed (model, τ or λ) pairs; every cell this runner computes must have them."""
        self.hyper = tuple(hyper)
        self.held = held_out(table)
        self.tests = Tests(table, self.held)
        self.table = pool_table(table, self.held.pool)
        self.dist = Distances(self.table)
        self._fitted = False
        self._context: SelectionContext | None = None  # the current seed's (cells come seed by seed)
        self._selections: dict[tuple, tuple[list[int] | None, str | None, float]] = {}

    def context(self, seed: int) -> SelectionContext:
        """The selection context of `seed`; every seed's shares the fitted learner models and one buffer."""
        if self._context is None or self._context.seed != seed:
            self._context = SelectionContext(self.table, seed=seed, dist=self.dist, like=self._context,
                                             hyperparameters=dict(self.hyper))
        return self._context

    def model(self, name: str):
        """The learner model `name` with its τ / λ chosen by the paper's rule on this table, fitted once."""
        ctx = self._context or self.context(0)
        return ctx.fitted(name)[0]

    def fit_all(self) -> None:
        """Every learner model fitted now (once), so that no selection's time holds a fit."""
        if not self._fitted:
            for name in LEARNER_NAMES:
                self.model(name)
            self._fitted = True

    def selection(self, cell: Cell) -> tuple[list[int] | None, str | None, float]:
        """(table rows shown, or None; the selector's refusal, or None; seconds it took)."""
        key = (cell.selector, cell.params, cell.seed)
        if key not in self._selections:
            ctx = self.context(cell.seed)
            start = time.perf_counter()
            try:
                envs, error = list(get_selector(cell.selector).select(ctx, **dict(cell.params)).envs), None
            except ValueError as exc:  # e.g. SCOT on a table with nothing to teach: a row that says so
                envs, error = None, str(exc)
            self._selections[key] = (envs, error, time.perf_counter() - start)
        return self._selections[key]

    def result(self, cell: Cell) -> tuple[dict, float]:
        """(the cell's result, its selection's seconds)."""
        if cell.hyper != self.hyper:
            raise ValueError(f"cell {cell.key} fixes τ / λ {dict(cell.hyper)}, this runner {dict(self.hyper)}")
        envs, error, seconds = self.selection(cell)
        out = {"cell": cell.describe(), "key": cell.key}
        if error is not None:
            return {**out, "error": error}, seconds
        model = self.model(cell.learner)
        log_post = log_posteriors(model, self.dist, envs)
        curve = np.exp(log_post[:, 0]).tolist()  # p_curve's P(θ*), from the posteriors the tests need anyway
        value = getattr(model, "value", None) if has_hyperparameter(model) else None
        return {**out, "env_ids": [int(e) for e in np.asarray(self.table.env_ids)[envs]], "p_theta_star": curve,
                "learner_value": None if value is None else float(value),
                "examples_to_criterion": examples_to_criterion(curve),
                "test_accuracy": self.tests.accuracy(model, log_post),
                "show_regret": self.tests.show_regret(log_post)}, seconds


def run_cells(table, cells: list[Cell], out, *, progress: Callable[[int, int], None] | None = None,
              runner: Runner | None = None) -> list[dict]:
    """Every cell's result, computing and writing those not yet in `out` (in the order given); `runner`: one of
    `table` kept from an earlier call (a worker's), so its distances and fits are not made again."""
    out = Path(out)
    results = []
    for done, cell in enumerate(cells, 1):
        path = result_path(out, cell)
        if path.exists():
            results.append(json.loads(path.read_text(encoding="utf-8")))
        else:
            runner = runner or Runner(table, cell.hyper)  # at the first missing cell: a finished run reads only
            runner.fit_all()
            result, seconds = runner.result(cell)
            write_atomically(out / "costs" / path.name, {"key": cell.key, "selection_seconds": seconds})
            write_atomically(path, result)
            results.append(result)
        if progress:
            progress(done, len(cells))
    return results


def read_results(out, cells: list[Cell]) -> list[dict]:
    """The stored results of `cells`, in their order; FileNotFoundError naming the first missing one."""
    results = []
    for cell in cells:
        path = result_path(Path(out), cell)
        if not path.exists():
            raise FileNotFoundError(f"no result for cell {cell.key} ({cell.selector}, {cell.learner}, seed "
                                    f"{cell.seed}) in {path.parent}")
        results.append(json.loads(path.read_text(encoding="utf-8")))
    return results


def batches(cells: list[Cell]) -> list[list[Cell]]:
    """The cells grouped by the selection they share (selector, parameters, seed), in first-seen order: the unit a
    worker takes, since one selection serves every learner."""
    groups: dict[tuple, list[Cell]] = {}
    for cell in cells:
        groups.setdefault((cell.selector, cell.params, cell.seed), []).append(cell)
    return list(groups.values())


_runner: tuple[tuple, Runner] | None = None  # this process's last table: a worker takes many of its batches


def run_batch(table_path, messages: list[dict], out) -> dict:
    """A worker's unit: the cells `messages` describe ({"cell": Cell.describe(), "key": ...}), of the table at
    `table_path`, computed into `out` as run_cells does.  The table is loaded, and its learners fitted, once per
    process.  ValueError if the table there is not the one the cells were planned on.  Returns counts."""
    global _runner
    cells = [Cell.from_description(m["cell"], m["key"]) for m in messages]
    path = str(Path(table_path).resolve())
    content_hash = json.loads((Path(path) / "meta.json").read_text(encoding="utf-8"))["content_hash"]
    hyper = cells[0].hyper if cells else ()
    if _runner is None or _runner[0] != (path, content_hash, hyper):
        _runner = ((path, content_hash, hyper), Runner(TrajectoryTable.load(path), hyper))
    wrong = {c.table for c in cells} - {content_hash}
    if wrong:
        raise ValueError(f"the table at {table_path} has content hash {content_hash[:16]}, not the planned "
                         f"{sorted(wrong)[0][:16]}: it changed since the benchmark was planned")
    stored = sum(result_path(Path(out), c).exists() for c in cells)
    run_cells(_runner[1].table, cells, out, runner=_runner[1])
    return {"cells": len(cells), "computed": len(cells) - stored}


def missing(out, cells: list[Cell]) -> int:
    """How many of `cells` have no result in `out` yet."""
    return sum(not result_path(Path(out), c).exists() for c in cells)


def timed(out, content_hash: str, cells: list[Cell], runner: str, compute: Callable[[], list[dict]]) -> list[dict]:
    """compute() (which computes `cells` of table `content_hash` into `out` and returns their results), its wall
    time recorded in <out>/runs/<content hash>.json where it computed any cell: how it ran ("in one process", "on
    Celery workers"), the seconds, the cells it computed, this machine's cores and the date (a board quotes it).
    A rerun that computed nothing keeps the record of the run that did."""
    before, start = missing(out, cells), time.perf_counter()
    results = compute()
    if before:
        write_atomically(Path(out) / "runs" / f"{content_hash}.json",
                         {"runner": runner, "seconds": time.perf_counter() - start, "computed": before,
                          "cells": len(cells), "cores": os.cpu_count(),
                          "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())})
    return results
