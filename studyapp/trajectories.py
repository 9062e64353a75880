"""Adapter from the numeric core (``teaching``) to the JSON a study stores.

A condition stores, per training environment, everything the browser needs
to draw it (robot states, the other car's positions, the goal), and the
study stores the shared test set with each option's robot states, so the
server never needs the trajectory table while a study runs.

Payload of one environment::

    {"env_id": 123, "goal": 0, "goal_name": "merge right", "other_lane": 2,
     "env_class": 0, "class_name": "merging", "cluster": 1, "dt": 0.25,
     "robot": [[x, y, heading, v, steer] * (T+1)], "other": [[x, y] * (T+1)],
     "world": {"lane_width": 12.0, "lane_centres": [-12.0, 0.0, 12.0], "road_half_width": 18.0,
               "car_length": 15.0, "car_width": 6.0}}

``world`` is :func:`scene_sizes`: the sizes the page draws the road and the cars with, from
teaching's ``WORLD`` (static/studyapp/scene.js has no sizes of its own).

A test adds ``options``: ``[{"theta_index", "is_theta_star", "cluster", "robot"}] * 4``
in canonical order (the display order is drawn per participant).

Both read a real ``teaching.core.table.TrajectoryTable``: :func:`training_from_table`
(theta*'s optimal trajectory in each training environment) and
:func:`test_set_from_table` (each test option's, from
``teaching.core.testset.select_test_set``).  No trajectory is drawn from anywhere else.
"""
from __future__ import annotations

import numpy as np

from teaching.api import (
    CLASS_NAMES,
    CLUSTER_NAMES,
    GOAL_NAMES,
    WORLD,
    get_environments,
    other_car_states,
)

DECIMALS = 3


def _rows(array) -> list:
    return np.round(np.asarray(array, dtype=float), DECIMALS).tolist()


def scene_sizes() -> dict:
    """The world's sizes a scene is drawn with (ft): lane width and centres (left to right), the
    road's half-width, the cars' length and width.  Taken from ``WORLD``, their one source."""
    return {
        "lane_width": float(WORLD.lane_width),
        "lane_centres": [float(x) for x in WORLD.lane_centres],
        "road_half_width": float(WORLD.road_half_width),
        "car_length": float(WORLD.car_length),
        "car_width": float(WORLD.car_width),
    }


def env_payload(env, robot, other, cluster) -> dict:
    """JSON for one environment; `env` is a one-element teaching Environments."""
    goal, cls = int(env.goal[0]), int(env.env_class[0])
    return {
        "env_id": int(env.ids[0]),
        "goal": goal,
        "goal_name": GOAL_NAMES[goal],
        "other_lane": int(env.other_lane[0]),
        "env_class": cls,
        "class_name": CLASS_NAMES[cls],
        "cluster": int(cluster),
        "cluster_name": CLUSTER_NAMES[int(cluster)],
        "dt": WORLD.dt,
        "robot": _rows(robot),
        "other": _rows(other),
        "world": scene_sizes(),
    }


def drawn_scene(payload: dict, *, robot: bool) -> dict:
    """What a participant's page may carry of an environment payload: what it draws.

    The goal (lane highlight), the time step, the other car's path and the world's sizes (road,
    lanes, cars); with `robot`, the yellow car's path too (a training example).  A test page
    draws four options, sent separately under their display letters; everything else in a
    payload (environment and theta ids, classes, strategy clusters, theta*'s own trajectory)
    stays on the server.  A payload stored before payloads carried ``world`` is drawn with
    today's :func:`scene_sizes`."""
    keys = ("goal", "dt", "other") + (("robot",) if robot else ())
    scene = {k: payload[k] for k in keys}
    scene["world"] = payload.get("world") or scene_sizes()
    return scene


# scene.js's INTERACTION_FT: the other car within this distance along the road is framed with the robot
INTERACTION_FT = 150.0


def framed_span(robot, other) -> float:
    """scene.js's framedSpan: the along-road gap (ft) a view must hold between the two cars (the
    largest while within INTERACTION_FT, and at least the gap at their closest approach)."""
    gaps = [abs(other[min(k, len(other) - 1)][1] - r[1]) for k, r in enumerate(robot)]
    near = [g for g in gaps if g <= INTERACTION_FT]
    return max(min(gaps), max(near, default=0.0))


def study_span(conditions, test_set) -> float:
    """The largest framed span of any training example or test option of a study: every canvas of
    the study is drawn at the one scale that holds it, so the same speeds and gaps look the same in
    training and at test (issue 22: test canvases drew at about half the training's px/ft)."""
    spans = [framed_span(env["robot"], env["other"]) for training in conditions for env in training]
    spans += [framed_span(o["robot"], t["other"]) for t in test_set for o in t["options"]]
    return round(max(spans, default=0.0), 1)


def option_payload(theta_index, is_theta_star, cluster, robot) -> dict:
    return {
        "theta_index": None if theta_index is None else int(theta_index),
        "is_theta_star": bool(is_theta_star),
        "cluster": int(cluster),
        "cluster_name": CLUSTER_NAMES[int(cluster)],
        "robot": _rows(robot),
    }


def check_test_set(tests: list[dict]) -> None:
    """Each test needs >= 2 options and exactly one that is theta*'s."""
    for j, test in enumerate(tests):
        if len(test["options"]) < 2:
            raise ValueError(f"test {j} has fewer than 2 options")
        if sum(bool(o["is_theta_star"]) for o in test["options"]) != 1:
            raise ValueError(f"test {j} must have exactly one theta* option")


# --- from a real trajectory table ----------------------------------------
def _env_index(table, env_id: int) -> int:
    hits = np.flatnonzero(np.asarray(table.env_ids) == env_id)
    if not len(hits):
        raise ValueError(f"environment {env_id} is not in the table")
    return int(hits[0])


def training_from_table(table, env_ids) -> list[dict]:
    """Payloads of theta*'s trajectories in the given environments, in order."""
    out = []
    for env_id in env_ids:
        i = _env_index(table, int(env_id))
        env = get_environments([int(env_id)])
        star = table.theta_star_index
        out.append(env_payload(env, table.states(i, star), other_car_states(env)[0], table.strategy[i, star]))
    return out


def test_set_from_table(table, test_set) -> list[dict]:
    """Payloads of a test set from ``teaching.core.testset.select_test_set``."""
    out = []
    for test in test_set:
        i = _env_index(table, int(test["env_id"]))
        env = get_environments([int(test["env_id"])])
        star = table.theta_star_index
        payload = env_payload(env, table.states(i, star), other_car_states(env)[0], table.strategy[i, star])
        for o in test["options"]:
            if not 0 <= int(o["theta_index"]) < table.n_thetas:
                raise ValueError(f"test in environment {test['env_id']}: theta index {o['theta_index']} is not "
                                 f"in the table (0..{table.n_thetas - 1})")
            if bool(o["is_theta_star"]) != (int(o["theta_index"]) == star):
                raise ValueError(f"test in environment {test['env_id']}: option theta {o['theta_index']} says "
                                 f"is_theta_star={o['is_theta_star']}, but theta* is theta {star} in this table")
        payload["options"] = [
            option_payload(o["theta_index"], o["is_theta_star"], table.strategy[i, o["theta_index"]],
                           table.states(i, o["theta_index"]))
            for o in test["options"]]
        out.append(payload)
    check_test_set(out)
    return out
