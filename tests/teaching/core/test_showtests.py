"""Show-the-way test selection: every test is checked against an eligibility worked out here with
plain loops over the table (not the module's helpers)."""
import numpy as np
import pytest

from teaching.core.conditions import build_sequences
from teaching.core.showtests import MIN_SHARE, select_show_tests
from teaching.core.testset import MIN_REGRET, TestSetError
from teaching.domains.driving.synthetic import synthetic_table


@pytest.fixture(scope="module")
def table():
    return synthetic_table(300, 80, n_candidates=6, seed=4)


@pytest.fixture(scope="module")
def training(table):
    return list(build_sequences(table, seed=0).values())


def brute_eligible(table, training, min_regret, min_share) -> dict[int, dict[int, float]]:
    """{test cluster: {env id: share of θ worse}} by the documented rule, one θ at a time."""
    used = {int(e) for seq in training for e in seq}
    features, star = np.asarray(table.features), [float(w) for w in table.theta_star]
    out = {int(c): {} for c in table.domain.test_clusters}
    for m, env_id in enumerate(int(e) for e in table.env_ids):
        c = int(table.strategy[m, 0])
        if env_id in used or c not in out:
            continue
        reward = [sum(w * float(f) for w, f in zip(star, features[m, j], strict=True)) for j in range(table.n_thetas)]
        worse = sum(1 for j in range(table.n_thetas) if reward[0] - reward[j] >= min_regret)
        if worse / table.n_thetas >= min_share:
            out[c][env_id] = worse / table.n_thetas
    return out


# the default share, and one at which some clusters of this table have no eligible environment
@pytest.mark.parametrize("min_share", [MIN_SHARE, 0.6])
@pytest.mark.parametrize("seed", [0, 3])
def test_one_eligible_environment_per_cluster_that_has_one(table, training, min_share, seed):
    eligible = brute_eligible(table, training, MIN_REGRET, min_share)
    tests = select_show_tests(table, training, seed=seed, min_share=min_share)
    assert [t["cluster"] for t in tests] == [c for c in table.domain.test_clusters if eligible[c]]
    if min_share == 0.6:
        assert len(tests) < len(table.domain.test_clusters)  # the case this threshold is here for
    used = {e for seq in training for e in seq}
    for t in tests:
        assert set(t) == {"env_id", "kind", "cluster", "share_worse"} and t["kind"] == "show"
        assert t["env_id"] not in used
        assert t["share_worse"] == pytest.approx(eligible[t["cluster"]][t["env_id"]])
    assert tests == select_show_tests(table, training, seed=seed, min_share=min_share)


def test_every_eligible_environment_can_be_drawn(table, training):
    eligible = brute_eligible(table, training, MIN_REGRET, 0.6)
    drawn = {c: set() for c in eligible}
    for seed in range(60):
        for t in select_show_tests(table, training, seed=seed, min_share=0.6):
            drawn[t["cluster"]].add(t["env_id"])
    assert drawn == {c: set(e) for c, e in eligible.items()}


def test_no_environment_from_training(table, training):
    first = select_show_tests(table, training, seed=1)
    again = select_show_tests(table, training + [[t["env_id"] for t in first]], seed=1)
    assert not {t["env_id"] for t in first} & {t["env_id"] for t in again}


def test_an_impossible_threshold_raises_one_line(table, training):
    with pytest.raises(TestSetError) as err:
        select_show_tests(table, training, min_share=1.0)  # θ* itself never has regret
    assert "\n" not in str(err.value) and "'merging: ahead'" in str(err.value) and ">= 0.001" in str(err.value)
    with pytest.raises(TestSetError):
        select_show_tests(table, [table.env_ids.tolist()])  # everything used for training
