"""The 21,216 driving environments, their stable ids and classes.

Enumeration order (documented, never to change): the id is the mixed-radix
number over the axes below, first axis most significant::

    goal        (2)  merge right, drive forward
    distance    (16) -240, -220, ..., -100, 100, 120, ..., 240   (other car's y at t=0)
    lane        (3)  left, centre, right
    v0          (13) 20, 25, ..., 80
    profile     (17) constant speed, then (t_a, v_f) for t_a in 0.5,1,1.5,2 and v_f in 20,30,70,80

An :class:`Environments` object holds these as parallel arrays so that every
later step (planner, features, strategies) is vectorised over environments.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.base import stratified_sample as core_stratified_sample
from .world import GOAL_FORWARD, GOAL_MERGE, WORLD, World

GOALS = np.array([GOAL_MERGE, GOAL_FORWARD])
DISTANCES = np.concatenate([np.arange(-240, -99, 20), np.arange(100, 241, 20)]).astype(float)
LANES = np.array([0, 1, 2])
V0S = np.arange(20, 81, 5).astype(float)
PROFILES = np.array([(0.0, np.nan)] + [(ta, vf) for ta in (0.5, 1.0, 1.5, 2.0) for vf in (20.0, 30.0, 70.0, 80.0)])
AXES = (len(GOALS), len(DISTANCES), len(LANES), len(V0S), len(PROFILES))
N_ENVIRONMENTS = int(np.prod(AXES))  # 21,216

MERGING, BRAKING, TAILGATING, OTHER = 0, 1, 2, 3
CLASS_NAMES = ("merging", "braking", "tailgating", "other")


@dataclass(frozen=True)
class Environments:
    """A batch of environments as parallel arrays, each of shape (n,)."""

    ids: np.ndarray  # int64
    goal: np.ndarray  # 0 merge, 1 forward
    other_y0: np.ndarray  # ft, relative to the robot's start
    other_lane: np.ndarray  # 0 left, 1 centre, 2 right
    other_v0: np.ndarray  # ft/s
    accel_time: np.ndarray  # s, 0 = constant speed
    v_final: np.ndarray  # ft/s (== v0 when accel_time == 0)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def other_x(self) -> np.ndarray:
        return np.asarray(WORLD.lane_centres)[self.other_lane]

    @property
    def env_class(self) -> np.ndarray:
        return environment_class(self)

    def take(self, index) -> Environments:
        return Environments(*(getattr(self, f)[index] for f in self.__dataclass_fields__))


def get_environments(ids=None) -> Environments:
    """Environments for the given ids (default: all 21,216, in id order)."""
    ids = np.arange(N_ENVIRONMENTS) if ids is None else np.asarray(ids, dtype=np.int64)
    if ids.ndim != 1:
        raise ValueError("environment ids must be a 1-D array")
    if len(ids) and (ids.min() < 0 or ids.max() >= N_ENVIRONMENTS):
        raise ValueError(f"environment ids must lie in [0, {N_ENVIRONMENTS}); got {ids.min()}..{ids.max()}")
    g, d, lane, v, p = np.unravel_index(ids, AXES)
    ta = PROFILES[p, 0]
    vf = np.where(ta > 0, PROFILES[p, 1], V0S[v])
    return Environments(ids.astype(np.int64), GOALS[g], DISTANCES[d], LANES[lane], V0S[v], ta, vf)


def environment_id(goal: int, distance: float, lane: int, v0: float, accel_time: float = 0.0, v_final=None) -> int:
    """The stable id of one environment, from its parameters."""
    try:
        d = int(np.flatnonzero(DISTANCES == distance)[0])
        v = int(np.flatnonzero(V0S == v0)[0])
        if accel_time == 0:
            p = 0
        else:
            p = 1 + 4 * [0.5, 1.0, 1.5, 2.0].index(accel_time) + [20.0, 30.0, 70.0, 80.0].index(v_final)
    except (IndexError, ValueError):
        raise ValueError(f"no such environment: distance={distance} v0={v0} t_a={accel_time} v_f={v_final}") from None
    if goal not in (0, 1) or lane not in (0, 1, 2):
        raise ValueError(f"no such environment: goal={goal} lane={lane}")
    return int(np.ravel_multi_index((goal, d, lane, v, p), AXES))


def environment_class(envs: Environments) -> np.ndarray:
    """Class of each environment (paper, Sec. "Example Domain")."""
    cls = np.full(len(envs), OTHER, dtype=np.int8)
    cls[(envs.other_lane == 2) & (envs.goal == GOAL_MERGE)] = MERGING
    centre_fwd = (envs.other_lane == 1) & (envs.goal == GOAL_FORWARD)
    cls[centre_fwd & (envs.other_y0 > 0)] = BRAKING
    cls[centre_fwd & (envs.other_y0 < 0)] = TAILGATING
    return cls


def other_car_states(envs: Environments, world: World = WORLD) -> np.ndarray:
    """Positions of the other car at steps 0..T: array (n, T+1, 2) of [x, y].

    Its speed changes linearly from v0 to v_f over t_a seconds, then holds;
    y is the exact integral of that speed profile.
    """
    t = np.arange(world.horizon + 1) * world.dt  # (T+1,)
    ta = envs.accel_time[:, None]
    v0, vf = envs.other_v0[:, None], envs.v_final[:, None]
    safe_ta = np.where(ta > 0, ta, 1.0)
    ramp = v0 * t + (vf - v0) * t**2 / (2 * safe_ta)
    after = v0 * ta + (vf - v0) * ta / 2 + vf * (t - ta)
    dy = np.where(ta > 0, np.where(t <= ta, ramp, after), v0 * t)
    y = envs.other_y0[:, None] + dy
    x = np.broadcast_to(envs.other_x[:, None], y.shape)
    return np.stack([x, y], axis=-1)


def stratified_sample(n: int, seed: int = 0) -> np.ndarray:
    """Sorted ids of a seeded sample of n environments, stratified by class.

    Each of the four classes gets an equal share (the informative classes are
    over-represented relative to the full grid, on purpose: they are where
    teaching happens).
    """
    return core_stratified_sample(environment_class(get_environments()), len(CLASS_NAMES), n, seed=seed)
