"""Adapter from the numeric core (``teaching``) to the JSON a study stores.

A condition stores, per training environment, everything the browser needs
to draw it (robot states, the other car's positions, the goal), and the
study stores the shared test set with each option's robot states, so the
server never needs the trajectory table while a study runs.

Payload of one environment::

    {"env_id": 123, "goal": 0, "goal_name": "merge right", "other_lane": 2,
     "env_class": 0, "class_name": "merging", "cluster": 1, "dt": 0.25,
     "robot": [[x, y, heading, v, steer] * (T+1)], "other": [[x, y] * (T+1)]}

A test adds ``options``: ``[{"theta_index", "is_theta_star", "cluster", "robot"}] * 4``
in canonical order (the display order is drawn per participant).

Two sources:

* :func:`training_from_table` / :func:`test_set_from_table` read a real
  ``teaching.table.TrajectoryTable``.
* :func:`placeholder_training` / :func:`placeholder_test_set` are a
  **PLACEHOLDER** used until the real demo table is wired in: environments
  come from ``teaching.environments``, but the robot's trajectories are
  synthesised here from simple hand-written rules (smooth lane changes at
  constant acceleration), *not* optimised for theta*.  Their strategy
  clusters are computed with the real ``teaching.strategies``.
"""
from __future__ import annotations

import numpy as np

from teaching.api import (
    CLASS_NAMES,
    CLUSTER_NAMES,
    GOAL_NAMES,
    WORLD,
    environment_class,
    get_environments,
    other_car_states,
    strategy_labels,
)

DECIMALS = 3


def _rows(array) -> list:
    return np.round(np.asarray(array, dtype=float), DECIMALS).tolist()


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
    }


def drawn_scene(payload: dict, *, robot: bool) -> dict:
    """What a participant's page may carry of an environment payload: what it draws.

    The goal (lane highlight), the time step and the other car's path; with `robot`, the
    yellow car's path too (a training example).  A test page draws four options, sent
    separately under their display letters; everything else in a payload (environment and
    theta ids, classes, strategy clusters, theta*'s own trajectory) stays on the server."""
    keys = ("goal", "dt", "other") + (("robot",) if robot else ())
    return {k: payload[k] for k in keys}


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
        out.append(env_payload(env, table.states(i, star), table.other_car(i), table.strategy[i, star]))
    return out


def test_set_from_table(table, test_set) -> list[dict]:
    """Payloads of a test set from ``teaching.testset.select_test_set``."""
    out = []
    for test in test_set:
        i = _env_index(table, int(test["env_id"]))
        env = get_environments([int(test["env_id"])])
        star = table.theta_star_index
        payload = env_payload(env, table.states(i, star), table.other_car(i), table.strategy[i, star])
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


# --- PLACEHOLDER trajectories (until the real demo table is wired in) -----
def synth_states(target_x: float = 0.0, t_start: float = 0.5, t_change: float = 2.0, accel: float = 0.0):
    """PLACEHOLDER: robot states (T+1, 5) of a smooth lane change to `target_x` at constant acceleration.

    x follows a smoothstep from 0 to target_x between t_start and t_start + t_change;
    speed changes by `accel` ft/s^2 (kept >= 0); heading and steering follow from the path.
    """
    t = np.arange(WORLD.horizon + 1) * WORLD.dt
    v = np.maximum(WORLD.v_init + accel * t, 0.0)
    y = np.concatenate([[0.0], np.cumsum((v[:-1] + v[1:]) / 2 * WORLD.dt)])
    s = np.clip((t - t_start) / t_change, 0.0, 1.0)
    x = target_x * s * s * (3 - 2 * s)
    dxdt = target_x * 6 * s * (1 - s) / t_change
    heading = np.arctan2(np.maximum(v, 1e-6), dxdt)
    dh = np.gradient(heading, WORLD.dt)
    steer = np.arctan(WORLD.wheelbase * dh / np.maximum(v, 1.0))
    return np.stack([x, y, heading, v, steer], axis=-1)


# (target_x, t_start, t_change, accel) variants per cluster, theta*-like first.
_VARIANTS = {
    0: [(12, 2.5, 2.0, 10.0), (12, 2.0, 2.0, 8.0)],  # merging: ahead
    1: [(12, 2.5, 2.0, -10.0), (12, 3.0, 1.5, -8.0)],  # merging: behind
    2: [(0, 0.5, 2.0, -8.0), (0, 0.5, 2.0, -4.0)],  # braking: stay
    3: [(-12, 0.5, 2.0, 0.0), (12, 1.0, 2.0, -2.0)],  # braking: change lane
    4: [(-12, 0.5, 2.0, 0.0), (12, 1.0, 2.0, 2.0)],  # tailgating: change lane
    5: [(0, 0.5, 2.0, 8.0), (0, 0.5, 2.0, 4.0)],  # tailgating: stay, speed up
}
_OTHER_CLUSTER = {0: 1, 1: 0, 2: 3, 3: 2, 4: 5, 5: 4}


def placeholder_policy(env) -> tuple:
    """PLACEHOLDER rule standing in for theta*'s optimal behaviour: (target_x, t_start, t_change, accel)."""
    goal, lane = int(env.goal[0]), int(env.other_lane[0])
    y0, vf = float(env.other_y0[0]), float(env.v_final[0])
    if goal == 0:
        if lane == 2:
            other_y = other_car_states(env)[0, 14, 1]  # at t = 3.5 s, mid lane change
            return _VARIANTS[1][0] if other_y > 3.5 * WORLD.v_init else _VARIANTS[0][0]
        return (12, 0.5, 2.0, 0.0)
    if lane == 1 and y0 > 0:  # braking
        return _VARIANTS[3][0] if (vf < 40 and y0 <= 180) else _VARIANTS[2][0]
    if lane == 1 and y0 < 0:  # tailgating
        return _VARIANTS[4][0] if (vf > 60 and y0 >= -160) else _VARIANTS[5][0]
    return (0, 0.5, 2.0, 0.0)


def _placeholder_env(env_id: int):
    env = get_environments([env_id])
    robot = synth_states(*placeholder_policy(env))
    other = other_car_states(env)[0]
    cluster = int(strategy_labels(robot[None], env, other[None])[0])
    return env, robot, other, cluster


def placeholder_training(env_ids) -> list[dict]:
    """PLACEHOLDER training payloads (synthesised trajectories, see module docstring)."""
    return [env_payload(*_placeholder_env(int(e))) for e in env_ids]


def placeholder_test_set(exclude=(), seed: int = 0) -> list[dict]:
    """PLACEHOLDER test set: one environment per informative cluster (6), 4 options each.

    Options: the placeholder theta* trajectory, one more from its cluster, two
    from the other cluster of the class.  theta_index is None for the
    synthesised alternatives (they come from no theta).
    """
    rng = np.random.default_rng(seed)
    all_envs = get_environments()
    cls = environment_class(all_envs)
    exclude = set(int(e) for e in exclude)
    tests = []
    for cluster in range(6):
        members = rng.permutation(np.flatnonzero(cls == cluster // 2))
        for env_id in members:
            if int(env_id) in exclude:
                continue
            env, robot, other, star_cluster = _placeholder_env(int(env_id))
            if star_cluster != cluster:
                continue
            params = placeholder_policy(env)
            same = [p for p in _VARIANTS[cluster] if tuple(p) != tuple(params)][0]
            candidates = [(0, True, params), (None, False, same)] + [
                (None, False, p) for p in _VARIANTS[_OTHER_CLUSTER[cluster]]]
            options = []
            for theta_index, is_star, p in candidates:
                states = synth_states(*p)
                label = int(strategy_labels(states[None], env, other[None])[0])
                options.append(option_payload(theta_index, is_star, label, states))
            if [o["cluster"] for o in options] != [cluster, cluster] + [_OTHER_CLUSTER[cluster]] * 2:
                continue  # the synthesised alternatives must really show both strategies here
            payload = env_payload(env, robot, other, star_cluster)
            payload["options"] = options
            tests.append(payload)
            break
        else:
            raise RuntimeError(f"no placeholder test environment found for cluster {cluster}")
    check_test_set(tests)
    return tests
