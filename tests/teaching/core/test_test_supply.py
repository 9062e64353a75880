"""The study designer's count of test environments (teaching.core.testsupply) against a brute force that
shares none of the selection's code: every environment, every 4-set of distinct trajectories tried with
itertools; and its rules for a whole test set (choice: every cluster; show: any) worked by hand."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from teaching.core.table import TrajectoryTable
from teaching.core.testset import MIN_REGRET
from teaching.core.testsupply import ANY, CHOOSE, TestSupply, clusters_without_a_test, supply_of_tests

pytestmark = pytest.mark.slow


def brute_hosts(table, min_regret: float, min_distance: float) -> dict[int, int]:
    """{test cluster: how many environments can hold its choice test}, by trying every option set.

    An environment holds a test of c when θ* shows c there (in c's class) and some [θ*, a, b, b'] exists:
    distinct trajectories, a of c, b and b' of c's sibling strategies (design rule) or of c's class (the
    relaxed rule, which contains the design one), each with θ*-regret >= min_regret, every pair at
    least min_distance apart."""
    domain = table.domain
    star = np.asarray(table.theta_star, np.float64)
    out = {}
    for c in domain.test_clusters:
        klass = domain.class_of_cluster[c]
        of_class = [k for k, kc in enumerate(domain.class_of_cluster) if kc == klass]
        n = 0
        for m in range(table.n_envs):
            strat = np.asarray(table.strategy[m])
            if strat[0] != c or table.env_class[m] != klass:
                continue
            value = np.asarray(table.features[m], np.float64) @ star
            by_way = {}  # one θ per distinct trajectory
            for t in range(table.n_thetas):
                by_way.setdefault(np.asarray(table.features[m, t]).tobytes(), t)
            ways = [t for t in sorted(by_way.values()) if t == 0 or value[0] - value[t] >= min_regret]
            states = {t: np.asarray(table.states(m, [t])[0], np.float64) for t in ways}

            def apart(x, y, states=states):
                return float(domain.euclidean_distance(states[x], states[y])) >= min_distance

            same = [t for t in ways if t != 0 and strat[t] == c]
            others = [t for t in ways if t != 0 and strat[t] in of_class]
            if any(apart(0, a) and all(apart(0, b) and apart(a, b) for b in pair) and apart(*pair)
                   for a in same for pair in itertools.combinations([t for t in others if t != a], 2)):
                n += 1
        out[c] = n
    return out


@pytest.fixture(scope="module", params=["tiny_table", "gridworld_tiny_table"])
def small_table(request):
    return TrajectoryTable.load(request.getfixturevalue(request.param))


@pytest.mark.parametrize("min_distance", [0.1, None])
def test_hosts_are_the_brute_forces(small_table, min_distance):
    distance = small_table.domain.min_option_distance if min_distance is None else min_distance
    supply = supply_of_tests(small_table, CHOOSE, min_distance=min_distance)
    expected = brute_hosts(small_table, MIN_REGRET, distance)
    assert supply.hosts == tuple(expected[c] for c in small_table.domain.test_clusters)
    assert clusters_without_a_test(small_table, CHOOSE, min_distance=min_distance) == [
        name for name, n in zip(supply.clusters, supply.hosts, strict=True) if not n]


def test_training_only_takes_environments_away(small_table):
    """The designer counts before training; the build's own count, with the training, is never larger."""
    before = supply_of_tests(small_table, CHOOSE, min_distance=0.1)
    training = [[int(e) for e in np.asarray(small_table.env_ids)[::3]]]
    after = supply_of_tests(small_table, CHOOSE, training, min_distance=0.1)
    assert all(a <= b for a, b in zip(after.hosts, before.hosts, strict=True))
    assert sum(after.hosts) < sum(before.hosts)


def test_a_whole_test_set_by_hand():
    """Choice tests need every cluster, show tests one; the refusal names what is missing and what to ask."""
    levels = {"low": (2, 0), "medium": (1, 1), "high": (0, 0)}
    choose = TestSupply(CHOOSE, ("left", "right"), (3, 1), levels)
    assert [choose.feasible(d) for d in (ANY, "low", "medium", "high")] == [True, False, True, False]
    assert choose.problem("low") == ("no environment of this table can hold a test of low difficulty of 'right': "
                                     "choose medium, or none.")
    assert choose.problem("high") == ("no environment of this table can hold a test of high difficulty of 'left', "
                                      "'right': choose medium, or none.")
    assert choose.problem(ANY) == ""
    show = TestSupply("show", ("left", "right"), (3, 1), levels)
    assert [show.feasible(d) for d in (ANY, "low", "medium", "high")] == [True, True, True, False]
    assert show.problem("high") == ("no environment of this table can hold a show test of high difficulty of any "
                                    "strategy: choose low or medium, or none.")
    none = TestSupply(CHOOSE, ("left",), (0,), {"low": (0,), "medium": (0,), "high": (0,)})
    assert none.problem("low").endswith("lower the minimum θ*-regret or distance.")
    assert none.problem(ANY).endswith("lower the minimum θ*-regret or distance, or choose another table.")
    assert choose.describe() == ["'left': 3 in all; 2 low, 1 medium, 0 high",
                                 "'right': 1 in all; 0 low, 1 medium, 0 high"]
    with pytest.raises(ValueError, match="unknown test kind 'pick'"):
        supply_of_tests(None, "pick")
