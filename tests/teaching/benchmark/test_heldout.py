"""The benchmark's held-out tests (teaching/benchmark/heldout.py): no selector shows a test's environment, the test
accuracy after each example is the study pilot's answer model's (teaching.core.simulate), and the show regret is
the belief-weighted θ*-regret worked out θ by θ from the table's features."""
from __future__ import annotations

import numpy as np
import pytest

from teaching.benchmark.cells import plan_cells
from teaching.benchmark.heldout import held_out
from teaching.benchmark.run import Runner, run_cells
from teaching.core.answers import questions_of
from teaching.core.learners import LEARNER_NAMES, Distances, has_hyperparameter
from teaching.core.simulate import AnswerModel, SimulatedLearner
from teaching.core.table import TrajectoryTable


@pytest.mark.parametrize("fixture", ["gridworld_tiny_table", "skateboard_tiny_table"])
def test_no_selector_shows_a_held_out_tests_environment(fixture, request, tmp_path):
    table = TrajectoryTable.load(request.getfixturevalue(fixture))
    held = held_out(table)
    assert len(held.choose) + len(held.show) >= 2 and len(held.pool) == table.n_envs - len(set(held.env_ids))
    results = run_cells(table, plan_cells(table.meta["content_hash"], seeds=2), tmp_path)
    shown = {e for r in results if "error" not in r for e in r["env_ids"]}
    assert shown and not shown & set(held.env_ids)
    again = held_out(table)  # the same tests for every cell and every run
    assert again.choose == held.choose and again.show == held.show and np.array_equal(again.pool, held.pool)


def test_test_accuracy_is_the_pilots_answer_model_after_each_example(gridworld_tiny_table, tmp_path):
    """AnswerModel (what a study's pilot and simulated participants use) with no lapse, on the whole table, takes
    float64 log-likelihoods where the benchmark takes float32 likelihoods: equal to 1e-6 of a probability."""
    table = TrajectoryTable.load(gridworld_tiny_table)
    runner = Runner(table)
    questions, star = questions_of(table, list(runner.held.choose))
    dist = Distances(table)
    results = run_cells(table, plan_cells(table.meta["content_hash"], selectors=["random", "scot"], seeds=1),
                        tmp_path)
    checked = 0
    for r in results:
        model = runner.model(r["cell"]["learner"])
        value = model.value if has_hyperparameter(model) else None
        answers = AnswerModel(table, SimulatedLearner(r["cell"]["learner"], value, lapse=0.0), questions, dist)
        rows = [table.row_of[e] for e in r["env_ids"]]
        expected = [answers.probabilities(tuple(rows[:t]))[np.arange(len(star)), star].mean()
                    for t in range(1, len(rows) + 1)]
        np.testing.assert_allclose(r["test_accuracy"], expected, rtol=0, atol=1e-6)
        assert r["show_regret"] is None  # the gridworld lets no one show the way
        checked += len(rows)
    assert checked > 2 * len(LEARNER_NAMES)


def test_show_regret_is_the_belief_weighted_theta_star_regret_theta_by_theta(skateboard_tiny_table, tmp_path):
    """For each prefix: the learner's weights Π_i L(E_i | θ) (float64), normalised; each show test's θ*-regret of θ's
    way, θ*·φ(ξ^θ*) − θ*·φ(ξ^θ), summed θ by θ from the stored features; within 1e-9 of the largest regret."""
    table = TrajectoryTable.load(skateboard_tiny_table)
    runner = Runner(table)
    dist = Distances(table)
    star = np.asarray(table.theta_star, np.float64)
    test_rows = [table.row_of[t["env_id"]] for t in runner.held.show]
    regret = [[float(star @ (np.asarray(table.features[m, 0], np.float64) - np.asarray(table.features[m, n])))
               for n in range(table.n_thetas)] for m in test_rows]
    scale = max(max(r) for r in regret)
    results = run_cells(table, plan_cells(table.meta["content_hash"], selectors=["random-uniform"], seeds=1), tmp_path)
    assert len(results) == len(LEARNER_NAMES) and all(len(r["show_regret"]) == len(r["env_ids"]) > 1 for r in results)
    for r in results:
        model = runner.model(r["cell"]["learner"])
        weights = np.ones(table.n_thetas)
        for t, e in enumerate(r["env_ids"]):
            weights = weights * model.likelihood(dist, rows=np.array([table.row_of[e]]))[0].astype(np.float64)
            belief = weights / weights.sum() if weights.sum() > 0 else np.full(table.n_thetas, 1 / table.n_thetas)
            expected = np.mean([sum(belief[n] * test[n] for n in range(table.n_thetas)) for test in regret])
            assert r["show_regret"][t] == pytest.approx(expected, abs=1e-9 * scale)
        assert r["test_accuracy"] is None  # the world file's table holds no choice test
