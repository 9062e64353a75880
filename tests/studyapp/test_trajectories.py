"""The adapter from the numeric core to the stored JSON: every trajectory comes from a table."""
import json

import numpy as np
import pytest

from studyapp import trajectories as tj
from teaching.api import TrajectoryTable
from teaching.domains.driving.domain import DOMAIN as DRIVING
from teaching.domains.driving.environments import environment_class, get_environments, other_car_states
from teaching.domains.driving.page import scene_sizes
from teaching.domains.driving.strategies import strategy_labels
from teaching.domains.driving.synthetic import synthetic_table
from teaching.domains.driving.world import WORLD


def check_env(payload):
    assert len(payload["robot"]) == 21 and all(len(r) == 5 for r in payload["robot"])
    assert len(payload["other"]) == 21 and all(len(r) == 2 for r in payload["other"])
    assert payload["robot"][0][:2] == [0.0, 0.0] and payload["dt"] == 0.25
    env = get_environments([payload["env_id"]])
    assert payload["goal"] == int(env.goal[0]) and payload["other_lane"] == int(env.other_lane[0])
    np.testing.assert_allclose(payload["other"], other_car_states(env)[0], atol=1e-3)


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
    table = synthetic_table(n_envs=16, n_thetas=8, seed=1)
    ids = [int(e) for e in table.env_ids]
    for p in tj.training_from_table(table, ids):
        assert p["env_class"] == int(environment_class(get_environments([p["env_id"]]))[0])


def test_training_is_theta_stars_optimal_trajectory_in_a_built_table(tiny_table):
    """On a table the planner built, a training payload is theta*'s trajectory from the table and
    its cluster the one the real labeller h(xi) gives it."""
    table = TrajectoryTable.load(tiny_table)
    ids = [int(e) for e in table.env_ids[::8]]
    for i, p in zip(range(0, table.n_envs, 8), tj.training_from_table(table, ids), strict=True):
        check_env(p)
        robot = np.asarray(p["robot"])
        np.testing.assert_allclose(robot, table.states(i, table.theta_star_index), atol=5e-4)
        env = get_environments([p["env_id"]])
        assert p["cluster"] == int(strategy_labels(robot[None], env)[0]) == int(table.strategy[i, 0])


# --- the world's sizes a scene is drawn with (one source: WORLD) ---------------------------
def test_payloads_carry_the_worlds_sizes_from_world():
    """Every training and test payload carries the sizes scenes/driving.js draws with, equal to WORLD's."""
    sizes = {"lane_width": WORLD.lane_width, "lane_centres": list(WORLD.lane_centres),
             "road_half_width": WORLD.road_half_width, "car_length": WORLD.car_length,
             "car_width": WORLD.car_width}
    assert scene_sizes() == sizes
    table = synthetic_table(n_envs=16, n_thetas=8, seed=1)
    ids = [int(e) for e in table.env_ids[:3]]
    spec = [{"env_id": ids[1], "options": [{"theta_index": k, "is_theta_star": k == 0} for k in (3, 0, 5, 1)]}]
    payloads = tj.training_from_table(table, ids) + tj.test_set_from_table(table, spec)
    for p in payloads:
        assert p["world"] == sizes
        assert json.loads(json.dumps(p))["world"] == sizes  # what a study stores (JSONField)


def test_drawn_scene_passes_the_payloads_sizes():
    table = synthetic_table(n_envs=16, n_thetas=8, seed=1)
    (p,) = tj.training_from_table(table, [int(table.env_ids[0])])
    p["world"] = {**p["world"], "lane_width": 16.0, "lane_centres": [-16.0, 0.0, 16.0]}  # the stored one wins
    for robot in (True, False):
        scene = tj.drawn_scene(p, robot=robot, domain=DRIVING)
        assert scene["world"] == p["world"]
        assert set(scene) == {"goal", "dt", "other", "world"} | ({"robot"} if robot else set())


def test_drawn_scene_of_a_payload_stored_before_sizes_gets_todays():
    """Payloads stored before they carried "world" are drawn with WORLD's sizes of today."""
    table = synthetic_table(n_envs=16, n_thetas=8, seed=1)
    (p,) = tj.training_from_table(table, [int(table.env_ids[0])])
    del p["world"]
    scene = tj.drawn_scene(p, robot=True, domain=DRIVING)
    assert scene["world"] == scene_sizes()
    assert set(scene) == {"goal", "dt", "other", "robot", "world"}


# --- the gridworld's payloads: the domain's scene, the path up to its arrival --------------
def test_gridworld_payloads_draw_the_tables_paths(gridworld_tiny_table):
    from teaching.domains.gridworld.environments import get_yard  # noqa: PLC0415

    table = TrajectoryTable.load(gridworld_tiny_table)
    grid = table.domain
    ids = [int(e) for e in table.env_ids]
    for i, p in enumerate(tj.training_from_table(table, ids)):
        yard = get_yard(ids[i])
        assert p["yard"]["cells"] == yard.cells.tolist()
        assert p["yard"]["start"] == [yard.start[1], yard.start[0]]  # [col, row]
        assert p["yard"]["goal"] == [yard.goal[1], yard.goal[0]]
        assert p["class_name"] == grid.class_names[int(table.env_class[i])]
        assert p["cluster"] == int(table.strategy[i, table.theta_star_index])
        path = np.asarray(p["robot"])
        assert path[0].tolist() == p["yard"]["start"] and path[-1].tolist() == p["yard"]["goal"]
        assert (np.abs(np.diff(path, axis=0)).sum(axis=1) == 1).all()  # one cell per move, no waiting
        stored = table.states(i, table.theta_star_index)  # padded by waiting at the drop-off
        np.testing.assert_array_equal(stored[:len(path)], path)
        assert (stored[len(path):] == path[-1]).all()
        scene = tj.drawn_scene(p, robot=True, domain=grid)
        assert set(scene) == {"dt", "yard", "robot"}  # the gridworld's whitelist: no id, class or cluster
