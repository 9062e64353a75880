"""The benchmark's tests, held out from teaching: what a simulated learner scores after each example.

Per table, one test set is drawn before any selection, as a study draws its own (seed 0): a choice test per test
cluster that can hold one (teaching.core.testset, four options, θ*'s among them) and, where the domain lets
participants show the way, a show test per cluster that can hold one (teaching.core.showtests).  Their
environments are taken out of the table the selectors teach from (`pool_table`), so no selector can show a test's
environment as an example, whichever mask it honours.

After each example t of a sequence, with the learner's posterior P(θ | first t examples):

* test accuracy: the mean over choice tests of P(the learner picks θ*'s option) by the choice model
  (teaching.core.choice) with no lapse: what an ideal participant of that model scores, in [0, 1];
* show regret: the mean over show tests of Σ_θ P(θ | ·) · regret_θ*(ξ^θ), the θ*-reward a learner forgoes by
  showing the way of an objective drawn from its belief, in θ*-reward units (teaching.core.testset
  `theta_star_regret`; 0: it shows θ*'s way).  A learner that ruled out every θ is taken to guess uniformly.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.special import logsumexp

from ..core.choice import OptionDistances, log_choice_probabilities
from ..core.domain import shows_the_way
from ..core.showtests import select_show_tests
from ..core.table import TrajectoryTable
from ..core.testset import TestSetError, select_test_set, theta_star_regret

SEED = 0  # the tests' draw: the same tests for every selector, learner and seed of a table


@dataclass(frozen=True)
class HeldOut:
    """choose: select_test_set's dicts; show: select_show_tests' (env_id; rows of the full table); pool: (M',)
    the full table's rows the selectors may teach from, in table order."""

    choose: tuple[dict, ...]
    show: tuple[dict, ...]
    pool: np.ndarray

    @property
    def env_ids(self) -> list[int]:
        return [int(t["env_id"]) for t in (*self.choose, *self.show)]


def held_out(table) -> HeldOut:
    """The table's tests (the module's rules; none of a kind the table cannot hold) and the rows left to teach."""
    choose = select_test_set(table, [], seed=SEED, skip_missing=True)
    try:
        show = select_show_tests(table, [], seed=SEED) if shows_the_way(table.domain) else []
    except TestSetError:
        show = []
    tests = {table.row_of[int(t["env_id"])] for t in (*choose, *show)}
    pool = np.array([m for m in range(table.n_envs) if m not in tests], np.int64)
    return HeldOut(tuple(choose), tuple(show), pool)


def pool_table(table, rows: np.ndarray) -> TrajectoryTable:
    """The table cut to `rows` (a copy of those rows in memory; the same objectives, meta and domain)."""
    if len(rows) == table.n_envs:
        return table
    return TrajectoryTable(table.thetas, np.asarray(table.env_ids)[rows], np.asarray(table.controls[rows]),
                           np.asarray(table.features[rows]), np.asarray(table.strategy[rows]),
                           np.asarray(table.d_euclid[rows]), table.normalisers, meta=dict(table.meta))


def log_posteriors(model, dist, sequence) -> np.ndarray:
    """(n, N) log P(θ | first t examples) for t = 1..n, the likelihoods taken as p_curve takes them (float32, then
    log), so that column 0 is log p_curve; a row is all -inf where the examples rule out every θ."""
    with np.errstate(divide="ignore"):
        lw = np.cumsum(np.log(model.likelihood(dist, rows=np.asarray(sequence, np.int64)).astype(np.float64)), 0)
    norm = logsumexp(lw, axis=1, keepdims=True)
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(norm), lw - norm, -np.inf)


class Tests:
    """A table's held-out tests, scored for any learner model (its option likelihoods computed once)."""

    def __init__(self, table, held: HeldOut):
        self.table, self.held = table, held
        self._option_logs: dict[object, np.ndarray] = {}

    @cached_property
    def star(self) -> np.ndarray:
        """(T,) the position of θ*'s option in each choice test."""
        return np.array([[o["is_theta_star"] for o in t["options"]].index(True) for t in self.held.choose], np.int64)

    @cached_property
    def regret(self) -> np.ndarray:
        """(S, N) θ*-regret of each θ's way in each show test's environment."""
        rows = [self.table.row_of[int(t["env_id"])] for t in self.held.show]
        return np.array([theta_star_regret(self.table, m) for m in rows], np.float64).reshape(len(rows), -1)

    def option_logs(self, model) -> np.ndarray:
        """(T, K, N) log P(option k of test t | θ) under `model` (there are choice tests)."""
        if model not in self._option_logs:
            options = [OptionDistances(self.table, t["env_index"], [o["theta_index"] for o in t["options"]])
                       for t in self.held.choose]
            self._option_logs[model] = np.stack([model.log_likelihood(o) for o in options])
        return self._option_logs[model]

    def accuracy(self, model, log_post: np.ndarray) -> list[float] | None:
        """(n,) mean P(θ*'s option) over the choice tests after each example; None without choice tests."""
        if not self.held.choose:
            return None
        p = log_choice_probabilities(log_post[:, None, None, :], self.option_logs(model)[None], 0.0)  # (n, T, K)
        return p[:, np.arange(len(self.star)), self.star].mean(axis=1).tolist()

    def show_regret(self, log_post: np.ndarray) -> list[float] | None:
        """(n,) mean expected θ*-regret over the show tests after each example; None without show tests."""
        if not self.held.show:
            return None
        belief = np.exp(log_post)
        lost = ~np.isfinite(log_post).any(axis=1)
        belief[lost] = 1.0 / belief.shape[1]
        return (belief @ self.regret.T).mean(axis=1).tolist()
