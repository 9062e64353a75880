"""Learner models against hand-worked likelihoods and brute-force optimality."""
from dataclasses import dataclass

import numpy as np
import pytest

from teaching.core import learners
from teaching.core.learners import (
    MODEL_NAMES,
    Distances,
    LearnerModel,
    check_value,
    make_model,
    model_names,
    p_curve,
    p_theta_star,
    posterior,
    register_model,
)
from teaching.core.selection import greedy
from teaching.domains.driving.synthetic import hand_table, synthetic_table

# 2 environments x 4 thetas (theta 0 = theta*), distances written by hand.
D_REWARD = np.array([[0.0, 0.5, 2.0, 0.0],
                     [0.0, 0.0, 3.0, 1e-9]])
D_EUCLID = np.array([[0.0, 0.2, 0.1, 4.0],
                     [0.0, 1.0, 0.0, 0.3]])
STRATEGY = np.array([[0, 0, 1, 1],
                     [3, 2, 3, 3]])


@pytest.fixture
def dist():
    return Distances(hand_table(D_REWARD, D_EUCLID, STRATEGY))


def test_reward_distance_is_the_hand_written_one(dist):
    np.testing.assert_allclose(dist.reward, D_REWARD, atol=1e-6)
    assert np.all(dist.reward[:, 0] == 0)


def test_exact_irl_keeps_theta_with_zero_reward_gap(dist):
    lik = make_model("exact").likelihood(dist)
    np.testing.assert_array_equal(lik, [[1, 0, 0, 1], [1, 1, 0, 1]])
    # after both examples theta* and theta 3 survive: P(theta*) = 1/2
    assert p_theta_star(make_model("exact"), dist, [0, 1]) == pytest.approx(0.5)


def test_exact_irl_keeps_exactly_the_thetas_for_which_the_shown_trajectory_is_optimal():
    table = synthetic_table(40, 30, n_candidates=5, seed=3)
    lik = make_model("exact").likelihood(Distances(table))
    for m in range(table.n_envs):
        feats, thetas = table.features[m], table.thetas
        # brute force: theta n keeps iff theta*'s trajectory is as good as every trajectory in the env
        best = (feats @ thetas.T).max(axis=0)  # (N,) best reward under each theta
        star = feats[0] @ thetas.T
        optimal = star >= best - 1e-9
        np.testing.assert_array_equal(lik[m].astype(bool), optimal, err_msg=f"env {m}")
    assert 0 < lik.mean() < 1  # the instance actually eliminates something and keeps something


def test_exact_irl_tolerance_is_in_normalised_reward_units():
    # hand_table's theta n (n >= 1) is -(n+1) e_0, so |theta_1| = 2 and |theta_9| = 10.  The same
    # raw gap of 5e-6 is 2.5e-6 normalised for theta 1 (not optimal: eliminated) but 5e-7 for
    # theta 9 (optimal to solver precision: kept).  Scaling theta must not change the verdict.
    d = np.zeros((1, 10))
    d[0, 1] = d[0, 9] = 5e-6
    lik = make_model("exact").likelihood(Distances(hand_table(d)))
    assert lik[0, 1] == 0 and lik[0, 9] == 1
    assert lik[0, [0, 2, 3, 4, 5, 6, 7, 8]].all()


def test_deterministic_likelihoods_by_hand(dist):
    np.testing.assert_array_equal(make_model("det-reward", 1.0).likelihood(dist), [[1, 1, 0, 1], [1, 1, 0, 1]])
    np.testing.assert_array_equal(make_model("det-euclidean", 0.25).likelihood(dist), [[1, 1, 1, 0], [1, 0, 1, 0]])
    np.testing.assert_array_equal(make_model("det-strategy").likelihood(dist), [[1, 1, 0, 0], [1, 0, 1, 1]])


def test_probabilistic_likelihoods_by_hand(dist):
    lam = np.log(2.0)
    lik = make_model("prob-reward", lam).likelihood(dist)
    np.testing.assert_allclose(lik[0], [1, 2 ** -0.5, 0.25, 1], rtol=1e-6)
    # P(theta* | env 0) = 1 / (1 + 2^-.5 + .25 + 1); both envs multiply the weights
    assert p_theta_star(make_model("prob-reward", lam), dist, [0]) == pytest.approx(1 / (2.25 + 2 ** -0.5), rel=1e-6)
    w = np.array([1, 2 ** -0.5, 2 ** -5, 1])  # env 1 adds factors 1, 1, 1/8, ~1
    assert p_theta_star(make_model("prob-reward", lam), dist, [0, 1]) == pytest.approx(1 / w.sum(), rel=1e-6)
    np.testing.assert_allclose(make_model("prob-euclidean", 2.0).likelihood(dist, rows=[1]),
                               [np.exp(-2 * D_EUCLID[1])], rtol=1e-6)


def test_prob_strategy_equals_det_strategy_for_every_value():
    dist = Distances(synthetic_table(30, 20, seed=5))
    det = make_model("det-strategy").likelihood(dist)
    for v in (1e-5, 1.0, 1e5):
        np.testing.assert_array_equal(make_model("prob-strategy", v).likelihood(dist), det)


def test_posterior_is_uniform_over_survivors_for_deterministic_models(dist):
    post = posterior(make_model("det-strategy"), dist, [0, 1])
    np.testing.assert_allclose(post, [1, 0, 0, 0])
    post = posterior(make_model("det-euclidean", 0.25), dist, [0])
    np.testing.assert_allclose(post, [1 / 3, 1 / 3, 1 / 3, 0])
    assert p_theta_star(make_model("exact"), dist, []) == pytest.approx(0.25)  # uniform prior


def test_p_curve_matches_prefix_posteriors():
    dist = Distances(synthetic_table(30, 25, seed=1))
    seq = [3, 7, 7, 12, 20]
    for name in MODEL_NAMES:
        model = make_model(name, None if name == "exact" else 0.3)
        curve = p_curve(model, dist, seq)
        expect = [p_theta_star(model, dist, seq[:t]) for t in range(1, len(seq) + 1)]
        np.testing.assert_allclose(curve, expect, rtol=1e-9)


def test_bad_names_and_values_are_refused():
    with pytest.raises(ValueError, match="unknown learner model"):
        make_model("det-manhattan")
    for bad in (0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="> 0"):
            make_model("det-euclidean", bad)
        with pytest.raises(ValueError):
            check_value("prob-reward", bad)


def test_a_new_model_plugs_into_the_selectors_without_touching_them():
    @dataclass(frozen=True)
    class Forgetful(LearnerModel):
        """Hypothetical: theta is judged by Euclidean distance, but only half as strictly."""
        value: float = 1.0
        name: str = "forgetful"
        param: str = "tau"

        def likelihood(self, dist, rows=None, out=None):
            d = dist.euclidean if rows is None else dist.euclidean[rows]
            return np.where(d <= 2 * self.value, 1.0, 0.5).astype(np.float32)

    register_model("forgetful", lambda v: Forgetful(1.0 if v is None else v))
    try:
        assert "forgetful" in model_names()
        model = make_model("forgetful", 0.05)
        dist = Distances(hand_table(D_REWARD, D_EUCLID, STRATEGY))
        seq, _ = greedy(model.likelihood(dist), max_examples=2)
        # env 0 halves thetas 1..3 except 2 (d=.1 <= .1): weights [1, .5, 1, .5]; env 1: [1, .5, 1, .5] too
        assert seq.envs[0] == 0
        assert p_theta_star(model, dist, [0]) == pytest.approx(1 / 3)
    finally:
        learners._REGISTRY.pop("forgetful")
