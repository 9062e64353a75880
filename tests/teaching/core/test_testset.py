"""Test-set selection: every documented constraint is checked on the result."""
import copy

import numpy as np
import pytest

from teaching.core.conditions import build_sequences
from teaching.core.domain import siblings
from teaching.core.testset import (
    MIN_REGRET,
    TestSetError,
    _distinct,
    pairwise_distance,
    select_test_set,
    theta_star_regret,
)
from teaching.domains.driving.domain import DOMAIN as DRIVING
from teaching.domains.driving.strategies import NO_STRATEGY
from teaching.domains.driving.synthetic import synthetic_table

MIN_OPTION_DISTANCE = DRIVING.min_option_distance


def sibling(c: int) -> int:
    (other,) = siblings(DRIVING, c)  # the car: two strategies per class
    return int(other)


@pytest.fixture(scope="module")
def table():
    return synthetic_table(300, 80, n_candidates=6, seed=4)


@pytest.fixture(scope="module")
def training(table):
    return list(build_sequences(table, seed=0).values())


def test_six_environments_with_the_promised_options(table, training):
    tests = select_test_set(table, training, seed=0)
    assert [t["cluster"] for t in tests] == [0, 1, 2, 3, 4, 5]
    used = {e for seq in training for e in seq}
    for t in tests:
        m, c = t["env_index"], t["cluster"]
        assert table.env_ids[m] == t["env_id"] and t["env_id"] not in used
        assert table.strategy[m, 0] == c  # theta* shows the cluster under test
        opts = t["options"]
        assert len(opts) == 4 and sum(o["is_theta_star"] for o in opts) == 1
        thetas = [o["theta_index"] for o in opts]
        assert len(set(thetas)) == 4
        star = next(o for o in opts if o["is_theta_star"])
        assert star["theta_index"] == 0
        clusters = [o["cluster"] for o in opts]
        assert clusters == [int(table.strategy[m, k]) for k in thetas]  # option = that theta's trajectory
        assert sorted(clusters) == sorted([c, c, sibling(c), sibling(c)])
        assert t["rule"] == "design"
        regret = theta_star_regret(table, m)
        for o in opts:
            assert o["regret"] == pytest.approx(regret[o["theta_index"]])
            if not o["is_theta_star"]:
                assert o["regret"] >= MIN_REGRET
        d = pairwise_distance(DRIVING, table.states(m, np.array(thetas)))
        assert d[np.triu_indices(4, 1)].min() >= MIN_OPTION_DISTANCE
        assert t["min_option_distance"] == pytest.approx(d[np.triu_indices(4, 1)].min())


def test_seeded_and_disjoint_from_any_training_list(table, training):
    a = select_test_set(table, training, seed=1)
    assert a == select_test_set(table, training, seed=1)
    # forbid the environments just chosen: the next test set avoids them
    b = select_test_set(table, training + [[t["env_id"] for t in a]], seed=1)
    assert not {t["env_id"] for t in a} & {t["env_id"] for t in b}


def test_impossible_constraints_raise(table, training):
    with pytest.raises(TestSetError, match="merging: ahead"):
        select_test_set(table, training, min_distance=1e6)
    with pytest.raises(TestSetError):
        select_test_set(table, [table.env_ids.tolist()])  # everything used for training


def test_regret_and_distance_by_hand(table):
    m = 3
    f = table.features[m]
    np.testing.assert_allclose(theta_star_regret(table, m), [(f[0] - f[n]) @ table.thetas[0] for n in range(len(f))])
    assert theta_star_regret(table, m)[0] == 0
    s = np.zeros((2, 21, 5))
    s[1, :, 0] = 12.0  # one lane to the right all the time; x scale is 12
    np.testing.assert_allclose(pairwise_distance(DRIVING, s), [[0, 1], [1, 0]])


def test_distinct_keeps_one_theta_per_trajectory(table):
    m = 0
    thetas = np.arange(table.n_thetas)
    kept = _distinct(table, m, thetas)
    assert len(kept) == len(np.unique(table.features[m], axis=0))
    assert kept[0] == 0  # the lowest index represents its trajectory


def test_relaxed_options_only_when_no_environment_has_the_other_strategy(table, training):
    """Where no θ in Θ ever takes the other strategy in cluster 0's environments (as merging on the demo
    table), the alternatives come from the class's strategies, never from trajectories showing none."""
    strategy = np.array(table.strategy)
    rows = np.flatnonzero(strategy[:, 0] == 0)
    block = strategy[rows]
    block[block == sibling(0)] = 0  # nobody merges on the other side ...
    block[:, 1::7] = NO_STRATEGY  # ... and some θs show no strategy at all
    strategy[rows] = block
    masked = copy.copy(table)  # a synthetic table keeps its candidates' states beside its fields
    masked.strategy = strategy
    tests = select_test_set(masked, training, seed=0)
    assert [t["rule"] for t in tests] == ["relaxed"] + ["design"] * 5
    opts = tests[0]["options"]
    assert all(o["cluster"] == 0 for o in opts)  # the class's strategies only: never NO_STRATEGY
    assert len({o["theta_index"] for o in opts}) == 4
    d = pairwise_distance(DRIVING, masked.states(tests[0]["env_index"], np.array([o["theta_index"] for o in opts])))
    assert d[np.triu_indices(4, 1)].min() >= MIN_OPTION_DISTANCE
