"""A mobile robot crossing a hallway among people: the worked example of a robot from outside the project
(docs/importing.md), with its own world, features and planner, in plain NumPy.

The hallway runs along x from 0 to 10 m and is 4 m wide (y from -2 to 2); the robot starts at (0, 0) and is
done on reaching x = 10 m.  Two people share it: one the environment is about (walking towards the robot,
crossing its way, or out of its way ahead) and a bystander at a wall.  All positions are in metres, every path
sampled every DT seconds up to HORIZON (a robot that has arrived waits there).

The planner searches a library of PLANS exhaustively: a start delay (go now, or wait 1 or 2 s), a cruising speed
and a lateral offset to hold through the middle of the hallway.  Each candidate objective θ weighs four costs
(FEATURES) and takes the plan of highest θ · φ, so every trajectory of the table is the best of the library
under its own objective, as the import's optimality check requires.
"""
from __future__ import annotations

import itertools

import numpy as np

DT = 0.25  # s between poses
HORIZON = 17.0  # s: the slowest plan (wait 2 s, then 10 m at 0.7 m/s) arrives by then
T = np.arange(0.0, HORIZON + DT / 2, DT)  # (L,) the clock
LENGTH, HALF_WIDTH = 10.0, 2.0  # m
COMFORT = 1.2  # m: a person closer than this is uncomfortably close
VIEW = (-0.5, 10.5, -2.6, 2.6)  # m: what every scene shows (x from, x to, y from, y to)
DOOR = 0.6  # m: half a doorway's width, where a crossing person comes through the walls

FEATURES = (("time", "s", "time until the robot reaches the far end"),
            ("closeness", "m s", "how long and how far inside 1.2 m of a person the robot is"),
            ("detour", "m", "how much longer the robot's path is than the straight line"),
            ("left_side", "s", "time spent in the left half of the hallway (people keep right)"))
THETA_STAR = (-1.0, -4.0, -0.5, -0.6)

CLASSES = ("oncoming", "crossing", "other")
STRATEGIES = (("oncoming: pass on its right", "oncoming"), ("oncoming: pass on its left", "oncoming"),
              ("crossing: let the person cross first", "crossing"), ("crossing: go ahead of the person", "crossing"))
# (delay s, speed m/s, lateral offset m; positive y is the robot's left)
PLANS = tuple(itertools.product((0.0, 1.0, 2.0), (0.7, 0.85, 1.0, 1.15, 1.3), (-1.2, -0.8, -0.4, 0.0, 0.4, 0.8, 1.2)))


def _smooth(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3 - 2 * u)


def robot_path(delay: float, speed: float, offset: float) -> np.ndarray:
    """(L, 2) the robot's poses [x, y]: it moves along x at `speed` after `delay`, easing over 2 m to hold
    `offset` from the centre line and back to it before the end."""
    x = np.clip(speed * (T - delay), 0.0, LENGTH)
    y = offset * np.minimum(_smooth(x / 2.0), _smooth((LENGTH - x) / 2.0))
    return np.stack([x, y], axis=1)


def person_path(kind: int, rng: np.random.Generator) -> np.ndarray:
    """(L, 2) the person an environment of class `kind` is about."""
    if kind == 0:  # oncoming: walks towards the robot along the hallway, near the centre
        start = np.array([rng.uniform(8.0, 12.0), rng.uniform(-0.4, 0.4)])
        velocity = np.array([-rng.uniform(0.7, 1.2), 0.0])
        return start + T[:, None] * velocity
    if kind == 1:  # crossing: walks across the hallway through the robot's way
        side = rng.choice([-1.0, 1.0])
        start = np.array([rng.uniform(3.5, 6.5), side * (HALF_WIDTH + 0.5)])
        at = np.clip(T - rng.uniform(0.0, 3.0), 0.0, None)  # starts walking a little later
        return start + at[:, None] * np.array([0.0, -side * rng.uniform(0.6, 1.0)])
    start = np.array([rng.uniform(11.0, 14.0), rng.uniform(-1.5, 1.5)])  # other: far ahead, walking away
    return start + T[:, None] * np.array([rng.uniform(0.3, 0.8), 0.0])


def bystander(rng: np.random.Generator) -> np.ndarray:
    """(L, 2) someone standing at a wall."""
    return np.tile([rng.uniform(2.0, 8.0), rng.choice([-1.0, 1.0]) * (HALF_WIDTH - 0.2)], (len(T), 1))


def walls(door: float | None) -> np.ndarray:
    """(4, 4) the hallway's walls as rectangles [x0, y0, x1, y1], each side in two parts, with a doorway
    around x = `door` on both sides (None: no doorway, the two parts meet)."""
    a, b = (door - DOOR, door + DOOR) if door is not None else (5.0, 5.0)
    return np.array([[x0, y0, x1, y1] for y0, y1 in ((-3.0, -HALF_WIDTH), (HALF_WIDTH, 3.0))
                     for x0, x1 in ((-1.0, a), (b, 11.0))])


def features(robot: np.ndarray, people: np.ndarray) -> np.ndarray:
    """robot (L, 2), people (A, L, 2) -> (4,) the costs FEATURES name."""
    arrived = np.flatnonzero(robot[:, 0] >= LENGTH - 1e-9)
    time = T[arrived[0]] if len(arrived) else HORIZON
    moving = T <= time
    d = np.linalg.norm(robot[None] - people, axis=-1)  # (A, L)
    closeness = float((np.clip(COMFORT - d, 0.0, None) * moving).sum() * DT)
    detour = float(np.linalg.norm(np.diff(robot, axis=0), axis=1).sum() - LENGTH)
    left = float(((robot[:, 1] > 0.05) & moving).sum() * DT)
    return np.array([time, closeness, detour, left])


def strategy(kind: int, robot: np.ndarray, person: np.ndarray) -> int:
    """The strategy a path shows (a position in STRATEGIES), -1 for none of its class's."""
    if kind == 0:  # which side of the person the robot is on when they meet
        k = int(np.argmin(np.abs(robot[:, 0] - person[:, 0])))
        return 0 if robot[k, 1] < person[k, 1] else 1
    if kind == 1:  # whether the robot is still short of the person's line when the person crosses y = 0
        k = int(np.argmin(np.abs(person[:, 1])))
        return 2 if robot[k, 0] < person[k, 0] else 3
    return -1


def candidates(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 4) objectives around θ*: each weight θ*'s times a log-uniform factor in [1/20, 20]."""
    return np.asarray(THETA_STAR) * np.exp(rng.uniform(-np.log(20), np.log(20), size=(n, len(THETA_STAR))))


def plan(n_envs: int, n_candidates: int, seed: int = 0) -> dict:
    """The whole table: env_id (M,), env_class (M,), thetas (N, 4) θ* first, features (M, N, 4), strategy
    (M, N), robot (M, N, L, 2), agents (M, 2, L, 2) and walls (M, 4, 4).  Every objective takes its best plan
    (the first of equal scores)."""
    rng = np.random.default_rng(seed)
    thetas = np.vstack([THETA_STAR, candidates(n_candidates, rng)])
    paths = np.stack([robot_path(*p) for p in PLANS])  # (P, L, 2): the same library in every environment
    kinds = np.arange(n_envs) % len(CLASSES)
    out = {"env_id": np.arange(n_envs), "env_class": kinds, "thetas": thetas,
           "features": np.empty((n_envs, len(thetas), 4)), "strategy": np.empty((n_envs, len(thetas)), np.int64),
           "robot": np.empty((n_envs, len(thetas), len(T), 2)), "agents": np.empty((n_envs, 2, len(T), 2)),
           "walls": np.empty((n_envs, 4, 4))}
    for m, kind in enumerate(kinds):
        people = np.stack([person_path(kind, rng), bystander(rng)])
        phi = np.stack([features(p, people) for p in paths])  # (P, 4)
        best = np.argmax(phi @ thetas.T, axis=0)  # (N,): each objective's plan
        out["features"][m] = phi[best]
        out["strategy"][m] = [strategy(kind, paths[b], people[0]) for b in best]
        out["robot"][m] = paths[best]
        out["agents"][m] = people
        out["walls"][m] = walls(people[0, 0, 0] if kind == 1 else None)
    return out
