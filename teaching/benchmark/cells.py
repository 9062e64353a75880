"""A benchmark cell: one selector's sequence on one table, learnt by one simulated learner, under one seed.

A cell is the unit of work.  Its result is content-addressed: the key hashes the table's content hash, the
selector's name and every parameter (checked, defaults filled), the learner, the seed, the criterion and the
format, so a rerun finds what is already computed, and changing any of them makes a new cell.  Which selectors
and learners there are is the registries' (teaching.core.selectors, teaching.core.learners): one registered
later joins the benchmark with no other change.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

from ..core.learners import LEARNER_NAMES, make_model
from ..core.selectors import check_params, selector_names

FORMAT = 3  # of a cell's result; a change of what a result holds bumps it, so older results are not reused
CRITERION = 0.5  # P(θ*) a learner must reach for "examples to criterion": θ* likelier than all others together


@dataclass(frozen=True)
class Cell:
    """table: the table's content hash; params: the selector's every parameter, sorted (name, value) pairs;
    learner: a learner model's name; seed: the selection's; hyper: sorted (model, τ or λ) pairs fixed for those
    models, as `teach --hyper` fixes them (the learners and the greedy selectors built for them alike), for
    instance the values a fit to participants' answers found; a model not named there has its τ / λ chosen by the
    paper's rule on the table."""

    table: str
    selector: str
    params: tuple[tuple[str, object], ...]
    learner: str
    seed: int
    hyper: tuple[tuple[str, float], ...] = ()

    @property
    def key(self) -> str:
        """32 hex digits naming this cell's result."""
        text = json.dumps({**self.describe(), "format": FORMAT, "criterion": CRITERION}, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:32]

    def describe(self) -> dict:
        """The cell as JSON; "hyper" only where some τ / λ is fixed."""
        out = {**asdict(self), "params": dict(self.params), "hyper": dict(self.hyper)}
        if not self.hyper:
            del out["hyper"]
        return out

    @classmethod
    def from_description(cls, described: dict, key: str) -> Cell:
        """The cell `describe()` gave, as a message or a result file carries it; ValueError if it is not the cell
        `key` names (a worker running other code than the client that planned it)."""
        params = tuple(sorted((name, tuple(v) if isinstance(v, list) else v)
                              for name, v in described["params"].items()))
        hyper = tuple(sorted((name, float(v)) for name, v in (described.get("hyper") or {}).items()))
        cell = cls(described["table"], described["selector"], params, described["learner"], int(described["seed"]),
                   hyper)
        if cell.key != key:
            raise ValueError(f"cell {key} reads back as {cell.key}: the worker's benchmark code differs from the "
                             "sender's (restart the workers on the same checkout)")
        return cell


def plan_cells(table_hash: str, *, selectors=None, learners=None, seeds: int = 10,
               hyper: dict[str, float] | None = None) -> list[Cell]:
    """Every (selector, learner, seed) cell of one table: `selectors` (names; default every registered one) with
    their default parameters, `learners` (default every learner model), seeds 0 .. seeds - 1, `hyper` {model: τ or
    λ} fixed (checked: parse_hyperparameters' values).  ValueError (one line) for an unknown name, a bad value or
    fewer than one seed."""
    selectors = tuple(selectors or selector_names())
    learners = tuple(learners or LEARNER_NAMES)
    if seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {seeds}")
    for name in learners:
        make_model(name)  # one line naming an unknown learner
    for name, value in (hyper or {}).items():
        make_model(name, value)  # one line naming a bad model or value
    fixed = tuple(sorted((name, float(v)) for name, v in (hyper or {}).items()))
    checked = {name: tuple(sorted(check_params(name).items())) for name in selectors}
    return [Cell(table_hash, name, checked[name], learner, seed, fixed)
            for seed in range(seeds) for name in selectors for learner in learners]
