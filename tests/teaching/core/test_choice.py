"""The choice model: option probabilities worked out by hand on a constructed table
of three θ, and the option distances checked against the table's own (built by the planner) on real
tables of both domains."""
from math import exp, sqrt

import numpy as np
import pytest

from teaching.core.build import PRESETS, build_table
from teaching.core.choice import OptionDistances, choice_probabilities, option_choice
from teaching.core.domain import get_domain
from teaching.core.learners import Distances, make_model
from teaching.core.table import TrajectoryTable


def padded(cells, length=32):
    """[col, row] states of a yard path, waiting at its last cell up to the table's length."""
    return np.array(list(cells) + [cells[-1]] * (length - len(cells)), np.float64)


# One yard, three θ (costs of [moves, mud cells]); θ0 and θ2 take path A, θ1 path B.
A = [(c, 0) for c in range(8)]                                        # 7 moves along row 0, 2 of them in mud
B = [(0, 0)] + [(c, 1) for c in range(8)] + [(7, 0)]                  # 9 moves, round the mud through row 1
PHI = {"A": (7.0, 2.0), "B": (9.0, 0.0)}
THETAS = np.array([[-1.0, -0.5], [-1.0, -2.0], [-1.0, -0.2]])         # θ0: A (-8 vs -9), θ1: B (-9 vs -11), θ2: A


class ThreeThetaTable:
    """The table interface OptionDistances reads, for one environment and three θ."""

    domain = get_domain("gridworld")
    thetas = THETAS
    n_thetas = 3
    features = np.array([[PHI["A"], PHI["B"], PHI["A"]]])            # (1, 3, 2)
    strategy = np.array([[0, 1, 0]])                                  # A and B are different strategies

    def states(self, env_index, theta_index):
        paths = [padded(A), padded(B), padded(A)]
        return np.stack([paths[int(n)] for n in np.atleast_1d(theta_index)])


TABLE = ThreeThetaTable()
D_AB = (7 * sqrt(2) + 1) / 9  # A vs B over B's 9 moves: 7 steps a diagonal cell apart, 1 step one cell, 1 together


def test_option_distances_by_hand():
    d = OptionDistances(TABLE, 0, [0, 1, 2])  # options: A, B, A again
    # reward θ_n gives up by driving option k: θ·φ(own) - θ·φ(option)
    np.testing.assert_allclose(d.reward, [[0, 2, 0], [1, 0, 1.6], [0, 2, 0]], atol=1e-6)
    np.testing.assert_allclose(d.euclidean, [[0, D_AB, 0], [D_AB, 0, D_AB], [0, D_AB, 0]], atol=1e-6)
    assert (d.strategy == [[0, np.inf, 0], [np.inf, 0, np.inf], [0, np.inf, 0]]).all()


@pytest.mark.parametrize("name, value, belief, lapse, expected", [
    # prob-reward, λ = 1, uniform belief: w = mean over θ of exp(-regret)
    ("prob-reward", 1.0, [1 / 3] * 3, 0.0,
     np.array([2 + exp(-2), exp(-1) + 1 + exp(-1.6), 2 + exp(-2)]) / (2 * (2 + exp(-2)) + exp(-1) + 1 + exp(-1.6))),
    # the same with a lapse rate of 0.2 over K = 3 options
    ("prob-reward", 1.0, [1 / 3] * 3, 0.2,
     0.8 * np.array([2 + exp(-2), exp(-1) + 1 + exp(-1.6), 2 + exp(-2)])
     / (2 * (2 + exp(-2)) + exp(-1) + 1 + exp(-1.6)) + 0.2 / 3),
    # exact IRL: option k counts the belief of the θ it is optimal for
    ("exact", None, [0.5, 0.25, 0.25], 0.0, np.array([0.75, 0.25, 0.75]) / 1.75),
    # det-euclidean: τ = 1 < d(A, B) keeps A and B apart; τ = 1.5 lets every θ accept every option
    ("det-euclidean", 1.0, [0.5, 0.25, 0.25], 0.0, np.array([0.75, 0.25, 0.75]) / 1.75),
    ("det-euclidean", 1.5, [0.5, 0.25, 0.25], 0.0, np.array([1, 1, 1]) / 3),
    ("prob-euclidean", 1.0, [0.5, 0.25, 0.25], 0.1,
     0.9 * np.array([0.75 + 0.25 * exp(-D_AB), 0.25 + 0.75 * exp(-D_AB), 0.75 + 0.25 * exp(-D_AB)])
     / (1.75 + 1.25 * exp(-D_AB)) + 0.1 / 3),
    ("det-strategy", None, [0.2, 0.6, 0.2], 0.0, np.array([0.4, 0.6, 0.4]) / 1.4),
    # hierarchical: another strategy rules a θ out, so B gets only θ1's belief; within A, d = 0
    ("hierarchical", 1.0, [0.5, 0.25, 0.25], 0.0, np.array([0.75, 0.25, 0.75]) / 1.75),
    ("hierarchical", 1.0, [1 / 3] * 3, 0.1, 0.9 * np.array([2, 1, 2]) / 5 + 0.1 / 3),
])
def test_choice_probabilities_by_hand(name, value, belief, lapse, expected):
    p = option_choice(make_model(name, value), np.array(belief), TABLE, 0, [0, 1, 2], lapse)
    np.testing.assert_allclose(p, expected, rtol=1e-6)
    assert p.sum() == pytest.approx(1.0)


def test_no_option_has_weight_the_learner_guesses():
    """All belief on θ1 (path B), options A and A: exact IRL gives both weight 0 -> 1/2 each, whatever ε."""
    for lapse in (0.0, 0.3):
        p = option_choice(make_model("exact"), np.array([0.0, 1.0, 0.0]), TABLE, 0, [0, 2], lapse)
        np.testing.assert_allclose(p, [0.5, 0.5])


# A fourth θ whose path C goes round through row 2: 13 moves, no mud.  θ0 (all belief) gives up 1 on B
# and 5 on C, so a question of options B and C lacks θ0's own trajectory and its rewards differ.
C = [(0, 0), (0, 1)] + [(c, 2) for c in range(8)] + [(7, 1), (7, 0)]


class FourThetaTable(ThreeThetaTable):
    thetas = np.vstack([THETAS, [[1.0, -5.0]]])  # θ3 likes moves and hates mud: C is its best path
    n_thetas = 4
    features = np.array([[PHI["A"], PHI["B"], PHI["A"], (13.0, 0.0)]])
    strategy = np.array([[0, 1, 0, 2]])

    def states(self, env_index, theta_index):
        paths = [padded(A), padded(B), padded(A), padded(C)]
        return np.stack([paths[int(n)] for n in np.atleast_1d(theta_index)])


@pytest.mark.parametrize("lam", [30.0, 1000.0])
def test_a_large_lambda_picks_the_option_that_gives_up_least(lam):
    """exp(-λ·1) and exp(-λ·5) are below float32's smallest number at λ 1000 (at λ 30 the second one is):
    computed directly, both weights were 0 and the learner guessed 1/2, or C's weight was 0; in log space
    P(B) = 1 / (1 + exp(-4λ)), what the model says."""
    model = make_model("prob-reward", lam)
    p = option_choice(model, np.array([1.0, 0.0, 0.0, 0.0]), FourThetaTable(), 0, [1, 3], 0.0)
    expected_c = exp(-4 * lam - np.logaddexp(0.0, -4 * lam))
    np.testing.assert_allclose(p, [1 - expected_c, expected_c], rtol=1e-9, atol=0)
    # the lapse mixes in a guess as before
    with_lapse = option_choice(model, np.array([1.0, 0.0, 0.0, 0.0]), FourThetaTable(), 0, [1, 3], 0.2)
    np.testing.assert_allclose(with_lapse, 0.8 * p + 0.1, rtol=1e-12)


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="lapse rate must lie in"):
        choice_probabilities(np.ones(3) / 3, np.ones((2, 3)), 1.5)
    with pytest.raises(ValueError, match="option theta indices"):
        OptionDistances(TABLE, 0, [0, 3])
    with pytest.raises(ValueError, match="non-empty"):
        OptionDistances(TABLE, 0, [])


@pytest.mark.parametrize("preset", ["tiny", "gridworld-tiny"])
def test_theta_stars_option_has_the_tables_own_distances(preset, tmp_path):
    """θ*'s trajectory as an option: its distances are the ones the learners learn from (Distances, from
    the stored features, strategies and the d_euclid the planner wrote at build time)."""
    build_table(PRESETS[preset], tmp_path / "t")
    table = TrajectoryTable.load(tmp_path / "t")
    dist = Distances(table)
    for m in range(0, table.n_envs, 7):
        d = OptionDistances(table, m, [table.theta_star_index, 3])
        np.testing.assert_allclose(d.reward[0], dist.reward[m], rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(d.euclidean[0], dist.euclidean[m], atol=1e-4)
        assert (d.strategy[0] == dist.strategy[m]).all()
        # and every model's choice over the options is a probability vector
        belief = np.full(table.n_thetas, 1.0 / table.n_thetas)
        for name in ("exact", "det-reward", "prob-euclidean", "det-strategy", "hierarchical"):
            p = option_choice(make_model(name), belief, table, m, [0, 3, 5, 7], 0.1)
            assert p.shape == (4,) and p.sum() == pytest.approx(1.0) and (p >= 0.1 / 4 - 1e-12).all()


def test_the_hierarchical_learner_is_strategy_then_closeness(tiny_table):
    """Its likelihood is the strategy learner's 0/1 times the probabilistic Euclidean learner's exp(-λ d)."""
    dist = Distances(TrajectoryTable.load(tiny_table))
    for lam in (0.3, 3.0):
        hier = make_model("hierarchical", lam).likelihood(dist)
        expected = make_model("det-strategy").likelihood(dist) * make_model("prob-euclidean", lam).likelihood(dist)
        np.testing.assert_array_equal(hier, expected)
        assert (hier[:, 0] == 1).all()  # θ* always explains its own example
