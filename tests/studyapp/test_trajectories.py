"""The adapter from the numeric core to the stored JSON, for real tables and for the placeholder."""
import numpy as np
import pytest

from studyapp import trajectories as tj
from teaching.environments import environment_class, get_environments, other_car_states
from teaching.strategies import strategy_labels
from teaching.synthetic import synthetic_table


def check_env(payload):
    assert len(payload["robot"]) == 21 and all(len(r) == 5 for r in payload["robot"])
    assert len(payload["other"]) == 21 and all(len(r) == 2 for r in payload["other"])
    assert payload["robot"][0][:2] == [0.0, 0.0] and payload["dt"] == 0.25
    env = get_environments([payload["env_id"]])
    assert payload["goal"] == int(env.goal[0]) and payload["other_lane"] == int(env.other_lane[0])
    np.testing.assert_allclose(payload["other"], other_car_states(env)[0], atol=1e-3)


def test_placeholder_training_payload():
    out = tj.placeholder_training([0, 5000, 20000])
    assert [p["env_id"] for p in out] == [0, 5000, 20000]
    for p in out:
        check_env(p)
        robot = np.array(p["robot"])
        env = get_environments([p["env_id"]])
        assert p["cluster"] == int(strategy_labels(robot[None], env)[0])  # the real h(xi)


def test_placeholder_test_set_matches_the_design():
    tests = tj.placeholder_test_set(exclude=[], seed=0)
    assert [t["cluster"] for t in tests] == [0, 1, 2, 3, 4, 5]  # one per informative cluster
    for t in tests:
        check_env(t)
        assert len(t["options"]) == 4 and sum(o["is_theta_star"] for o in t["options"]) == 1
        star = next(o for o in t["options"] if o["is_theta_star"])
        assert star["robot"] == t["robot"] and star["cluster"] == t["cluster"]
        same = sum(o["cluster"] == t["cluster"] for o in t["options"])
        assert same == 2  # theta*'s, one more from its cluster, two from the other
        robots = [np.array(o["robot"]) for o in t["options"]]
        assert all(np.abs(a - b).max() > 1 for i, a in enumerate(robots) for b in robots[i + 1:])


def test_placeholder_test_set_avoids_training_envs():
    first = tj.placeholder_test_set(seed=0)
    used = [t["env_id"] for t in first]
    again = tj.placeholder_test_set(exclude=used, seed=0)
    assert not set(used) & {t["env_id"] for t in again}


def test_synth_states_are_kinematically_consistent():
    s = tj.synth_states(12, 0.5, 2.0, 4.0)
    assert s.shape == (21, 5)
    assert s[-1, 0] == pytest.approx(12) and s[0, 3] == 50 and s[-1, 3] == pytest.approx(70)
    assert np.all(np.diff(s[:, 1]) > 0)


def test_from_a_real_table():
    table = synthetic_table(n_envs=16, n_thetas=8, seed=1)
    ids = [int(e) for e in table.env_ids[:3]]
    training = tj.training_from_table(table, ids)
    for i, p in enumerate(training):
        check_env(p)
        np.testing.assert_allclose(p["robot"], table.states(i, 0), atol=1e-3)
        assert p["cluster"] == int(table.strategy[i, 0])
    spec = [{"env_id": ids[1], "options": [{"theta_index": k, "is_theta_star": k == 0} for k in (3, 0, 5, 1)]}]
    (test,) = tj.test_set_from_table(table, spec)
    assert [o["theta_index"] for o in test["options"]] == [3, 0, 5, 1]
    assert [o["is_theta_star"] for o in test["options"]] == [False, True, False, False]
    np.testing.assert_allclose(test["options"][2]["robot"], table.states(1, 5), atol=1e-3)
    with pytest.raises(ValueError, match="not in the table"):
        tj.training_from_table(table, [int(np.setdiff1d(np.arange(21216), table.env_ids)[0])])
    with pytest.raises(ValueError, match="exactly one theta"):
        tj.test_set_from_table(table, [{"env_id": ids[0], "options": [{"theta_index": 1, "is_theta_star": False},
                                                                      {"theta_index": 2, "is_theta_star": False}]}])


def test_env_class_recorded():
    (p,) = tj.placeholder_training([12870])
    assert p["env_class"] == int(environment_class(get_environments([12870]))[0])
