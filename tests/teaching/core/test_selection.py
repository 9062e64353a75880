"""Selectors against exhaustive search, hand-built instances and their own definitions."""
import copy
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from teaching.core.conditions import build_sequences, condition_sequence, teach
from teaching.core.learners import MODEL_NAMES, Distances, make_model, p_theta_star
from teaching.core.selection import (
    CONDITIONS,
    GRID,
    Sequence,
    SweepRow,
    choose_hyperparameter,
    coverage_augmented,
    coverage_random,
    greedy,
    random_baseline,
    sweep,
    theta_star_clusters,
)
from teaching.domains.driving.strategies import NO_STRATEGY
from teaching.domains.driving.synthetic import hand_table, synthetic_table

DETERMINISTIC = ("exact", "det-reward", "det-euclidean", "det-strategy", "prob-strategy")


def keep_masks(min_m=2, max_m=7, max_n=12):
    """Random 0/1 likelihood matrices with theta* (column 0) never eliminated."""
    shape = st.tuples(st.integers(min_m, max_m), st.integers(2, max_n))
    return shape.flatmap(lambda s: arrays(np.bool_, s)).map(lambda a: _with_star(a))


def _with_star(a):
    a = a.copy()
    a[:, 0] = True
    return a


def eliminated(keep: np.ndarray, subset) -> int:
    """Number of thetas the examples in subset eliminate (the deterministic objective)."""
    if len(subset) == 0:
        return 0
    return int(keep.shape[1] - np.logical_and.reduce(keep[list(subset)], axis=0).sum())


def project_objective(keep: np.ndarray, model_name: str):
    """The deterministic objective computed by the project's own learner code: the number of
    thetas eliminated by a set of examples, N - 1 / P_M(theta* | examples) (the posterior is
    uniform over the survivors, theta* among them).  `keep` becomes distances 0 / 1 in the
    metric the model reads, and tau = 0.5 keeps exactly the zeros."""
    dist = np.where(keep, 0.0, 1.0)
    if model_name == "det-euclidean":
        table = hand_table(np.zeros(keep.shape), d_euclid=dist)
    else:
        table = hand_table(dist)
    distances = Distances(table)
    model = make_model(model_name) if model_name == "exact" else make_model(model_name, 0.5)

    def f(subset) -> int:
        return int(round(keep.shape[1] - 1 / p_theta_star(model, distances, sorted(subset))))

    return f


@settings(max_examples=150, deadline=None)
@given(keep_masks(), st.data(), st.sampled_from(["exact", "det-reward", "det-euclidean"]))
def test_deterministic_objective_is_monotone_and_submodular(keep, data, model_name):
    m = keep.shape[0]
    a = data.draw(st.sets(st.integers(0, m - 1)))
    b = a | data.draw(st.sets(st.integers(0, m - 1)))  # A subset of B
    e = data.draw(st.integers(0, m - 1))
    f = project_objective(keep, model_name)
    assert f(a) == eliminated(keep, sorted(a))  # the learner code agrees with the set definition
    assert f(b) >= f(a)  # monotone
    assert f(a | {e}) - f(a) >= f(b | {e}) - f(b)  # diminishing returns


@settings(max_examples=150, deadline=None)
@given(keep_masks(), st.integers(1, 3))
def test_greedy_is_within_1_minus_1_over_e_of_the_best_k_set(keep, k):
    seq, _ = greedy(keep.astype(np.float32), max_examples=k)
    best = max(eliminated(keep, s) for s in itertools.combinations(range(keep.shape[0]), min(k, keep.shape[0])))
    assert eliminated(keep, seq.envs) >= (1 - 1 / np.e) * best
    # P(theta*) reported by greedy is 1 / survivors
    if seq.envs:
        assert seq.p[-1] == pytest.approx(1 / (keep.shape[1] - eliminated(keep, seq.envs)))


def test_greedy_by_hand_picks_largest_elimination_then_stops():
    keep = np.array([[1, 1, 0, 0, 1, 1],   # eliminates {2, 3}
                     [1, 0, 0, 0, 1, 1],   # eliminates {1, 2, 3}   <- first
                     [1, 1, 1, 1, 0, 1],   # eliminates {4}         <- second (ties with env 3, lower index)
                     [1, 1, 1, 1, 1, 0],   # eliminates {5}         <- third
                     [1, 0, 1, 1, 1, 1]],  # eliminates {1}: nothing new once env 1 is shown
                    dtype=np.float32)
    seq, _ = greedy(keep)
    assert seq.envs == [1, 2, 3]
    np.testing.assert_allclose(seq.p, [1 / 3, 1 / 2, 1.0])


def test_greedy_respects_the_cap_and_prob_models_may_repeat():
    lik = np.array([[1.0, 0.5, 0.5]], np.float32)  # one environment, probabilistic
    seq, _ = greedy(lik, max_examples=10)
    assert seq.envs == [0] * 10 and seq.n_unique == 1
    np.testing.assert_allclose(seq.p[-1], 1 / (1 + 2 * 0.5 ** 10), rtol=1e-5)
    seq, _ = greedy(lik, max_examples=10, allow_repeats=False)
    assert seq.envs == [0]


@pytest.fixture(scope="module")
def small():
    table = synthetic_table(160, 60, n_candidates=6, seed=11)
    return table, Distances(table), teach(table, seed=3)


def test_own_greedy_sequence_is_best_for_deterministic_users_unless_capped(small):
    table, dist, result = small
    for user in DETERMINISTIC:
        model = result.models[user]
        own = result.sequences[user]
        p_own = p_theta_star(model, dist, own.envs)
        for other in list(MODEL_NAMES) + ["random", "coverage-random", "coverage-approx*"]:
            p_other = p_theta_star(model, dist, result.sequences[other].envs)
            if len(own.envs) < 10:
                assert p_own >= p_other - 1e-12, (user, other)
        # when the cap does not bind, greedy has reached the intersection of all environments
        if len(own.envs) < 10:
            keep = model.likelihood(dist).astype(bool)
            assert p_own == pytest.approx(1 / np.logical_and.reduce(keep, axis=0).sum())


def test_coverage_adds_exactly_the_missing_clusters():
    # 8 thetas; what each env eliminates, and theta*'s cluster in it
    kills = {0: [1, 2, 3, 4, 5], 1: [6], 2: [7], 3: [1], 4: [6], 5: []}
    clusters = np.array([0, 0, 2, 1, 1, 5])
    lik = np.ones((6, 8), np.float32)
    for m, ks in kills.items():
        lik[m, ks] = 0
    # eps = .18: env 0 lifts P from 1/8 to 1/3 (gain .21); the best next gain is 1/3 -> 1/2 (.17 < eps):
    # stop.  Missing clusters 1, 2, 5; best first: env 2 (P 1/2, ties env 4, lower index), then env 4
    # (P 1; env 3 of the same cluster kills nothing new), then env 5.
    seq = coverage_augmented(lik, clusters, n_clusters=8, epsilon=0.18)
    assert seq.envs == [0, 2, 4, 5] and seq.added_for_coverage == [2, 4, 5]
    np.testing.assert_allclose(seq.p, [1 / 3, 1 / 2, 1, 1])
    # eps = .01: greedy runs to P = 1 with [0, 1, 2] (clusters 0, 0, 2); then one each for 1 and 5
    seq = coverage_augmented(lik, clusters, n_clusters=8, epsilon=0.01)
    assert seq.envs == [0, 1, 2, 3, 5] and seq.added_for_coverage == [3, 5]
    # eps = .25: the first gain (.21) is already too small; every cluster is added exactly once
    seq = coverage_augmented(lik, clusters, n_clusters=8, epsilon=0.25)
    assert seq.envs == [0, 2, 4, 5] and seq.added_for_coverage == seq.envs
    for s in (seq,):
        assert sorted(clusters[s.added_for_coverage].tolist()) == [0, 1, 2, 5]


def test_coverage_keeps_greedy_prefix_when_epsilon_is_tiny(small):
    table, dist, result = small
    model = result.models["det-euclidean"]
    lik = model.likelihood(dist)
    clusters = theta_star_clusters(table)
    plain, _ = greedy(lik)
    cov = coverage_augmented(lik, clusters, n_clusters=8, epsilon=1e-12)
    n = len(cov.envs) - len(cov.added_for_coverage)
    assert cov.envs[:n] == plain.envs
    present = set(np.unique(clusters).tolist())
    missing = present - set(clusters[plain.envs].tolist())
    assert sorted(clusters[cov.added_for_coverage].tolist()) == sorted(missing)
    assert set(clusters[cov.envs].tolist()) == present


def test_random_baseline_is_the_median_by_rank(small):
    table, dist, _ = small
    seq, p, chosen = random_baseline(dist, np.random.default_rng(7), n_draws=101, length=8)
    # redraw the same sequences and score them independently
    rng = np.random.default_rng(7)
    draws = [rng.choice(table.n_envs, size=8, replace=False) for _ in range(101)]
    exact = make_model("exact")
    scores = np.array([p_theta_star(exact, dist, d) for d in draws])
    np.testing.assert_allclose(p, scores, rtol=1e-9)
    assert seq == draws[chosen].tolist()
    assert scores[chosen] == np.sort(scores)[50]
    assert (scores < scores[chosen]).sum() <= 50 <= (scores <= scores[chosen]).sum() - 1
    assert len(set(seq)) == 8


def test_coverage_random_takes_one_env_per_present_cluster(small):
    table = small[0]
    clusters = theta_star_clusters(table)
    seq = coverage_random(clusters, np.random.default_rng(0), 8)
    assert clusters[seq].tolist() == sorted(np.unique(clusters).tolist())
    assert seq == coverage_random(clusters, np.random.default_rng(0), 8)


def test_hyperparameter_rule_on_constructed_sweep():
    def row(value, envs, p):
        return SweepRow(value, Sequence(envs=envs, p=p, prior=0.01))

    rows = [row(1e-2, [5], [0.9]),                          # one example: rise 0
            row(1e-1, [1, 2, 3, 4, 5], [0.1, 0.12, 0.13, 0.14, 0.15]),  # most unique, rise .05: rejected
            row(1.0, [1, 2, 3], [0.1, 0.3, 0.5]),           # 3 unique, rise .4
            row(10.0, [1, 2, 1, 3], [0.2, 0.5, 0.6, 0.9]),  # 3 unique, rise .7, higher final P: chosen
            row(100.0, [], [])]
    assert choose_hyperparameter(rows) == (10.0, True)
    assert choose_hyperparameter(rows, min_rise=0.75) == (10.0, False)  # none qualifies: largest rise, flagged
    assert choose_hyperparameter(rows[:3]) == (1.0, True)


def test_hyperparameter_sweep_on_constructed_table():
    # theta 1..4; env 0 puts every theta at distance .5, env k (1..4) puts theta k at distance 5
    d = np.zeros((5, 5))
    d[0, 1:] = 0.5
    for k in range(1, 5):
        d[k, k] = 5.0
    dist = Distances(hand_table(np.zeros((5, 5)), d_euclid=d))
    rows = sweep(make_model("det-euclidean"), dist)
    by = {r.value: r.sequence for r in rows}
    assert by[1e-5].envs == [0] and by[0.1].envs == [0]  # too strict: one example decides
    assert by[1.0].envs == [1, 2, 3, 4]                   # four examples, P: 1/4 .. 1
    np.testing.assert_allclose(by[1.0].p, [1 / 4, 1 / 3, 1 / 2, 1])
    assert by[10.0].envs == [] and by[1e5].envs == []     # too lenient: nothing teaches
    assert choose_hyperparameter(rows) == (1.0, True)
    assert len(rows) == len(GRID) == 11


def test_build_sequences_is_seeded_and_names_every_condition(small):
    table = small[0]
    a = build_sequences(table, seed=3)
    assert tuple(a) == CONDITIONS
    assert a == build_sequences(table, seed=3)
    ids = set(table.env_ids.tolist())
    assert all(set(v) <= ids for v in a.values())
    assert len(a["random"]) == 8
    b = build_sequences(table, seed=4)
    assert b["random"] != a["random"]
    assert {k: v for k, v in a.items() if "random" not in k} == {k: v for k, v in b.items() if "random" not in k}
    c = teach(table, seed=3, approx_star="prob-euclidean").sequences
    cov = c["coverage-approx*"]
    n = len(cov.envs) - len(cov.added_for_coverage)
    assert cov.envs[:n] == c["prob-euclidean"].envs[:n]  # greedy under prob-euclidean until the gain < eps


def test_fixed_hyperparameters_skip_the_sweep(small):
    table = small[0]
    result = teach(table, hyperparameters={"det-euclidean": 0.5})
    assert result.models["det-euclidean"].value == 0.5
    assert "det-euclidean" not in result.sweeps
    with pytest.raises(ValueError):
        teach(table, hyperparameters={"det-euclidean": 0.0})
    with pytest.raises(ValueError):
        teach(table, approx_star="nope")


@pytest.mark.parametrize("hyper", [{}, {"det-euclidean": 0.1, "prob-reward": 10.0}])
def test_each_condition_alone_equals_the_whole_teaching_run(hyper):
    """condition_sequence (one worker task) and teach (every condition at once) give the same sequences,
    P(θ*) curves, models and rule outcomes."""
    table = synthetic_table(90, 40, n_candidates=5, seed=5)
    whole = teach(table, seed=4, hyperparameters=hyper)
    for name in CONDITIONS:
        seq, model, met = condition_sequence(table, name, seed=4, hyperparameters=hyper)
        assert seq.envs == whole.sequences[name].envs, name
        np.testing.assert_array_equal(seq.p, whole.sequences[name].p)
        assert seq.added_for_coverage == whole.sequences[name].added_for_coverage
        key = {"random": "exact", "coverage-random": "det-euclidean", "coverage-approx*": "det-euclidean"}.get(
            name, name)
        assert model == whole.models[key], name
        assert met == whole.rule_met.get(key), name
    with pytest.raises(ValueError, match="unknown condition"):
        condition_sequence(table, "nope")


def test_environments_where_theta_star_shows_no_strategy_are_never_shown():
    """A table where the most informative environments are ones in which θ*'s trajectory is labelled
    NO_STRATEGY (e.g. a merge along the lane line): no condition, sweep value or random draw shows them."""
    table = synthetic_table(90, 40, n_candidates=5, seed=5)
    best = teach(table, seed=4)
    hidden = sorted({e for name in CONDITIONS for e in best.sequences[name].envs})
    strategy = np.array(table.strategy)
    strategy[hidden, 0] = NO_STRATEGY  # θ*'s label only: the θs' own trajectories keep theirs
    masked = copy.copy(table)  # a synthetic table keeps its candidates' states beside its fields
    masked.strategy = strategy
    result = teach(masked, seed=4)
    for name in CONDITIONS:
        assert not set(result.sequences[name].envs) & set(hidden), name
        assert len(result.sequences[name].envs) > 0, name
    for rows in result.sweeps.values():
        for row in rows:
            assert not set(row.sequence.envs) & set(hidden)
    # coverage never tries to "cover" the non-strategy
    assert NO_STRATEGY not in theta_star_clusters(masked)[result.sequences["coverage-approx*"].envs]


def test_greedy_rescales_weights_so_tiny_likelihoods_do_not_underflow():
    """A sharp probabilistic learner gives likelihoods ~1e-30; two examples multiply to 1e-60, below
    float32's range.  P(θ*) is scale-free, so greedy rescales w after each example; without that the
    second candidate scores 0/0 and selection stops after one example.  By hand: env 0 shrinks θ1
    100-fold, env 1 θ2, so two examples give P(θ*) = 1 / (1 + 0.01 + 0.01)."""
    lik = np.array([[1e-30, 1e-32, 1e-30],
                    [1e-30, 1e-30, 1e-32]], np.float32)
    seq, w = greedy(lik, max_examples=2)
    assert sorted(seq.envs) == [0, 1]
    assert seq.p[-1] == pytest.approx(1 / 1.02, rel=1e-5)
    assert w.max() == 1.0 and w[0] == 1.0
