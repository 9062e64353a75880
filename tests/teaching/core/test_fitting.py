"""Fitting learner models to answers: parameter recovery from participants simulated
by this file's own brute-force learner (loops over θ on the table's raw features and states, none of
teaching's learner, choice or fitting code), model recovery on the demo study's design, merging of
identical models, and the bad inputs a researcher can hit."""
import functools

import numpy as np
import pytest
from scipy.optimize import minimize, minimize_scalar

from teaching.core.answers import Answers, FitError, Question
from teaching.core.conditions import teach
from teaching.core.fitting import (
    _answer_log_lik,
    choice_table,
    compare_models,
    fit_model,
    fit_models,
    option_distances,
    tie_ranks,
)
from teaching.core.learners import Distances, make_model
from teaching.core.recovery import model_recovery
from teaching.core.selection import CONDITIONS
from teaching.core.simulate import SimulatedLearner, simulate_answers
from teaching.core.table import TrajectoryTable
from teaching.core.testset import select_test_set


# --- a learner written out by hand, for simulating ---------------------------------------------------
def brute_distance(table, metric):
    """d(e, θ, ref): how far θ's optimal trajectory in environment e is from θ ref's, from the table's raw
    arrays.  Memoised: every condition asks for the same (environment, θ, option) again."""
    thetas = np.asarray(table.thetas, np.float64)
    feats = np.asarray(table.features, np.float64)

    @functools.cache
    def dist(e, th, ref):
        if metric == "reward":
            return float(thetas[th] @ (feats[e, th] - feats[e, ref]))
        return float(table.domain.euclidean_distance(table.states(e, th), table.states(e, ref)))

    return dist


def brute_choice(table, dist, kind, value, lapse, sequence, env, options):
    """(K,) P(option): belief over θ from `sequence`'s θ* examples, then each option's belief-weighted
    likelihood, normalised, mixed with the lapse rate; `dist` is brute_distance's."""
    n = table.n_thetas

    def lik(d):
        return float(d <= value) if kind == "det" else float(np.exp(-value * d))

    belief = np.array([np.prod([lik(dist(e, th, 0)) for e in sequence]) for th in range(n)])
    belief /= belief.sum()
    w = np.array([sum(belief[th] * lik(dist(env, th, o)) for th in range(n)) for o in options])
    return (1 - lapse) * w / w.sum() + lapse / len(options)


def brute_answers(table, metric, kind, value, lapse, sequences, tests, n_per_sequence, rng):
    names = list(sequences)
    group = np.repeat(np.arange(len(names)), n_per_sequence)
    dist = brute_distance(table, metric)
    probs = {g: [brute_choice(table, dist, kind, value, lapse, sequences[names[g]], t.env_index, t.options)
                 for t in tests] for g in range(len(names))}
    choice = np.array([[rng.choice(len(p), p=p) for p in probs[g]] for g in group])
    return Answers(sequence_names=tuple(names), sequences=tuple(tuple(sequences[n]) for n in names),
                   tests=tuple(tests), group=group, choice=choice)


@pytest.fixture(scope="module")
def grid_design(gridworld_table):
    """The gridworld table, its 9 conditions' sequences (table rows) and 12 tests of θ* and 3 other θ."""
    table = TrajectoryTable.load(gridworld_table)
    result = teach(table)
    sequences = {c: result.sequences[c].envs for c in CONDITIONS}
    rng = np.random.default_rng(5)
    shown = {e for s in sequences.values() for e in s}
    envs = rng.choice([e for e in range(table.n_envs) if e not in shown], 12, replace=False)
    tests = [Question(int(e), (0,) + tuple(int(o) for o in rng.choice(np.arange(1, table.n_thetas), 3, replace=False)))
             for e in envs]
    return table, sequences, tests


@pytest.mark.parametrize("name, metric, kind, value, lapse", [
    ("prob-euclidean", "euclidean", "prob", 3.0, 0.15),
    ("det-euclidean", "euclidean", "det", 0.3, 0.05),
    ("prob-reward", "reward", "prob", 0.3, 0.25),
])
def test_a_fit_recovers_the_simulated_learners_parameters(grid_design, name, metric, kind, value, lapse):
    table, sequences, tests = grid_design
    answers = brute_answers(table, metric, kind, value, lapse, sequences, tests, 60, np.random.default_rng(1))
    fit = fit_model(name, table, answers)
    assert abs(fit.lapse - lapse) <= 0.05, fit
    assert abs(np.log10(fit.value) - np.log10(value)) <= 1.0, fit
    # the deterministic learner's likelihood is a step in τ: the fitted τ must lie on the true step
    if kind == "det":
        refit = fit_model(name, table, answers, grid=(value, fit.value))
        assert refit.log_lik == pytest.approx(fit.log_lik, abs=1e-6)
    assert fit.n_answers == 9 * 60 * 12
    assert fit.n_params == 2 and fit.aic == pytest.approx(4 - 2 * fit.log_lik)
    assert fit.bic == pytest.approx(2 * np.log(fit.n_answers) - 2 * fit.log_lik)
    # cross-validated below in-sample, and not by much at 540 participants
    assert fit.log_lik - 5 < fit.cv_log_lik < fit.log_lik


@pytest.fixture(scope="module")
def demo_design(demo_table):
    """The demo table with its conditions' sequences and the study's own test set (select_test_set)."""
    table = TrajectoryTable.load(demo_table)
    result = teach(table)
    sequences = {c: result.sequences[c].envs for c in CONDITIONS}
    ids = np.asarray(table.env_ids)
    test_set = select_test_set(table, [[int(ids[e]) for e in s] for s in sequences.values()])
    tests = [Question(t["env_index"], tuple(o["theta_index"] for o in t["options"])) for t in test_set]
    return table, result, sequences, tests


@pytest.mark.parametrize("generator", ["det-euclidean", "prob-reward"])
def test_data_simulated_from_a_model_is_best_explained_by_it(demo_design, generator):
    """Two models the demo design tells apart: each one's simulated study is fitted best by itself."""
    table, result, sequences, tests = demo_design
    learner = SimulatedLearner(generator, result.models[generator].value, 0.1)
    answers = simulate_answers(table, learner, sequences, tests, 270, np.random.default_rng(3))
    fits = fit_models(table, answers)
    assert fits[0].name == generator, [(f.label, f.cv_log_lik) for f in fits]
    assert min(fits, key=lambda f: f.bic).name == generator
    # the ratings follow the generating model's probabilities
    assert fits[0].rating_rho > 0.5


@pytest.fixture(scope="module")
def lapsing_study(demo_design):
    """161 prob-euclidean participants at λ 0.316, ε 0.2 on the demo design: the shape where a search of ε,
    then λ, once each stopped 0.07 short of the maximum of ℓ."""
    table, result, sequences, tests = demo_design
    return simulate_answers(table, SimulatedLearner("prob-euclidean", 0.316, 0.2), sequences, tests, 161,
                            np.random.default_rng(0))


@pytest.mark.parametrize("name", ["det-reward", "det-euclidean", "prob-reward", "prob-euclidean", "hierarchical"])
def test_the_fit_reports_the_maximum_of_its_own_likelihood(demo_design, lapsing_study, name):
    """Every model with a parameter: the reported ℓ is the project's pooled ℓ at the reported (τ / λ, ε), and
    neither a dense grid over (τ / λ, ε) (ten values a decade, ε in steps of 1/400) nor a local search from
    that grid's best finds a higher one."""
    table, _, _, _ = demo_design
    answers = lapsing_study
    dist = Distances(table)
    options = option_distances(table, answers.tests)
    base = make_model(name)

    def pooled(values, eps):  # (V, E) Σ_i ℓ_i, the fit's own likelihood
        q = np.stack([choice_table(base.with_value(v), dist, options, answers.sequences) for v in values])
        return _answer_log_lik(q, answers, np.asarray(eps, np.float64)).sum(-1)

    fit = fit_model(name, table, answers, dist=dist, options=options)
    assert pooled([fit.value], [fit.lapse])[0, 0] == pytest.approx(fit.log_lik, abs=1e-9)
    log_values, eps = np.linspace(-5, 5, 101), np.linspace(0, 1, 401)
    dense = pooled(10.0 ** log_values, eps)
    g, e = np.unravel_index(int(np.argmax(dense)), dense.shape)
    assert fit.log_lik >= dense[g, e] - 1e-6, (fit.value, fit.lapse, 10.0 ** log_values[g], eps[e])
    if name.startswith("det"):  # a step function of τ: the grid's best step, with ε searched on it
        local = minimize_scalar(lambda x: -pooled([10.0 ** log_values[g]], [x])[0, 0], bounds=(0, 1),
                                method="bounded", options={"xatol": 1e-9})
    else:
        local = minimize(lambda x: -pooled([10.0 ** x[0]], [x[1]])[0, 0], [log_values[g], eps[e]],
                         method="Nelder-Mead", bounds=[(-5, 5), (0, 1)], options={"xatol": 1e-8, "fatol": 1e-10})
    assert fit.log_lik >= -local.fun - 1e-6, (fit.value, fit.lapse, local.x)


def test_identical_models_are_one_entry(demo_design):
    table, result, sequences, tests = demo_design
    answers = simulate_answers(table, SimulatedLearner("det-strategy", None, 0.1), sequences, tests, 90,
                               np.random.default_rng(0))
    fits = fit_models(table, answers)
    labels = [f.label for f in fits]
    assert "det-strategy = prob-strategy" in labels
    assert not any(f.name == "prob-strategy" for f in fits)
    assert len(fits) == 7  # eight models, two of them one


# --- bad input -----------------------------------------------------------------------------------
def test_no_answers_one_condition_and_lapses_give_one_line_messages(demo_design):
    table, result, sequences, tests = demo_design
    rng = np.random.default_rng(0)
    answers = simulate_answers(table, SimulatedLearner("det-euclidean", 1.0, 0.1), sequences, tests, 36, rng)
    unanswered = Answers(answers.sequence_names, answers.sequences, answers.tests, answers.group,
                         np.full_like(answers.choice, -1))
    with pytest.raises(FitError, match="no participant answered a test"):
        fit_models(table, unanswered)
    nobody = Answers(answers.sequence_names, answers.sequences, answers.tests, answers.group[:0],
                     answers.choice[:0])
    with pytest.raises(FitError, match="no participant answered"):
        fit_models(table, nobody)
    one = simulate_answers(table, SimulatedLearner("det-euclidean", 1.0, 0.1), {"exact": sequences["exact"]},
                           tests, 30, rng)
    with pytest.raises(FitError, match="one condition"):
        fit_models(table, one)
    guesses = Answers(answers.sequence_names, answers.sequences, answers.tests, np.repeat(np.arange(9), 20),
                      rng.integers(0, 4, (180, len(tests))))
    with pytest.raises(FitError, match="better than guessing") as err:
        fit_models(table, guesses)
    assert "\n" not in str(err.value)
    with pytest.raises(FitError, match="no test set"):
        fit_models(table, Answers(answers.sequence_names, answers.sequences, (), answers.group, answers.choice))


def test_the_comparison_ranks_models_and_selects_across_participants(demo_design):
    table, result, sequences, tests = demo_design
    answers = simulate_answers(table, SimulatedLearner("det-euclidean", result.models["det-euclidean"].value, 0.1),
                               sequences, tests, 180, np.random.default_rng(7))
    comparison = compare_models(table, answers)
    rows = comparison.rows()
    assert [r["model"] for r in rows][0] == "det-euclidean"
    assert [r["cv_log_lik"] for r in rows] == sorted((r["cv_log_lik"] for r in rows), reverse=True)
    assert min(r["delta_bic"] for r in rows) == 0
    assert sum(r["exceedance"] for r in rows) == pytest.approx(1)
    assert rows[0]["exceedance"] == max(r["exceedance"] for r in rows)
    assert comparison.n_participants == 180
    single = compare_models(table, answers, ["det-euclidean"])
    assert single.bms is None and np.isnan(single.rows()[0]["exceedance"])


def test_tie_ranks_share_a_rank_within_the_tolerance():
    ranks, tied = tie_ranks([-10.0, -10.0 + 5e-7, -12.0, -9.0, -12.0 - 2e-6])
    assert ranks == [2, 2, 4, 1, 5]
    assert tied == [[1], [0], [], [], []]


def test_tied_models_are_reported_tied(demo_design):
    """Exact-IRL learners: exact and the approximate models that equal it at their fitted τ / λ predict every
    answer alike, so their held-out log-likelihoods agree.  They share rank 1, each names the others, the
    exceedance probability is split among them (equal shares) and their together is reported; the next model
    ranks after all of them."""
    table, result, sequences, tests = demo_design
    answers = simulate_answers(table, SimulatedLearner("exact", None, 0.15), sequences, tests, 90,
                               np.random.default_rng(0))
    rows = compare_models(table, answers).rows()
    top = [r for r in rows if r["rank"] == 1]
    assert len(top) >= 2 and "exact" in [r["model"] for r in top], [(r["model"], r["cv_log_lik"]) for r in rows]
    names = {r["model"] for r in top}
    for r in top:
        assert set(r["tied_with"]) == names - {r["model"]}
        assert r["cv_log_lik"] == pytest.approx(top[0]["cv_log_lik"], abs=1e-6)
        assert r["exceedance"] == pytest.approx(top[0]["exceedance"], abs=1e-6)
        assert r["tie_exceedance"] == pytest.approx(sum(t["exceedance"] for t in top))
    rest = [r for r in rows if r["rank"] != 1]
    assert rest[0]["rank"] == len(top) + 1 and not rest[0]["tied_with"]
    assert rest[0]["tie_exceedance"] == rest[0]["exceedance"]


def test_model_recovery_counts_winners_and_parameters(demo_design):
    table, result, sequences, tests = demo_design
    gens = {"det-euclidean": SimulatedLearner("det-euclidean", result.models["det-euclidean"].value, 0.15),
            "prob-reward": SimulatedLearner("prob-reward", result.models["prob-reward"].value, 0.15),
            "det-strategy": SimulatedLearner("det-strategy", None, 0.15)}
    rec = model_recovery(table, sequences, tests, gens, 180, reps=2, seed=4)
    assert rec.confusion.shape == (3, len(rec.fitted))
    assert rec.confusion.sum() + sum(rec.unfitted.values()) + sum(len(t) for t in rec.ties.values()) == 6
    # columns in the registry's order, the strategy learners as one
    assert rec.fitted.index("det-euclidean") < rec.fitted.index("prob-reward")
    assert "det-strategy = prob-strategy" in rec.fitted
    assert rec.recovered("det-euclidean") == rec.recovered("prob-reward") == 1.0
    assert rec.column("det-strategy") == rec.fitted.index("det-strategy = prob-strategy")
    assert rec.lapse_recovered("det-euclidean") == 1.0 and rec.value_recovered("prob-reward") == 1.0
    assert rec.value_recovered("det-strategy") is None and len(rec.lapses["det-strategy"]) == 2
    for gen, _label, share in rec.confused(threshold=0.5):
        assert gen == "det-strategy" and share >= 0.5  # the hierarchical learner nests it (λ -> 0)
