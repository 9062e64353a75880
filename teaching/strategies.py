"""Strategy clusters h(xi): 8 in all, two per environment class (DESIGN §2).

Computed from the trajectory itself, never from theta:

* merging: at the first step the robot's x passes half a lane towards the
  right lane (or at T if it never does), is it ahead of the other car (y gap > 0)?
* braking / tailgating: does the robot ever leave the centre lane
  (|x| > half a lane)?
* other: by goal (merge / forward), one cluster each.
"""
from __future__ import annotations

import numpy as np

from .environments import BRAKING, MERGING, OTHER, TAILGATING, Environments, environment_class, other_car_states
from .world import GOAL_MERGE, WORLD

MERGE_AHEAD, MERGE_BEHIND, BRAKE_STAY, BRAKE_CHANGE, TAIL_CHANGE, TAIL_STAY, OTHER_MERGE, OTHER_FORWARD = range(8)
N_CLUSTERS = 8
CLUSTER_NAMES = (
    "merging: ahead", "merging: behind",
    "braking: stay in lane", "braking: change lane",
    "tailgating: change lane", "tailgating: stay (speed up)",
    "other: merge", "other: forward",
)
CLASS_OF_CLUSTER = np.array([MERGING, MERGING, BRAKING, BRAKING, TAILGATING, TAILGATING, OTHER, OTHER])


def strategy_labels(states: np.ndarray, envs: Environments, other_xy: np.ndarray | None = None) -> np.ndarray:
    """Cluster of each trajectory.

    states: (n, N, T+1, 5) robot states of N trajectories in each of the n
    environments (or (n, T+1, 5) for one trajectory each).  Returns int8
    (n, N) (or (n,)).
    """
    single = states.ndim == 3
    if single:
        states = states[:, None]
    if other_xy is None:
        other_xy = other_car_states(envs)
    cls = environment_class(envs)[:, None]
    half = WORLD.lane_width / 2
    x, y = states[..., 0], states[..., 1]  # (n, N, T+1)

    entered = x >= half
    first = np.where(entered.any(-1), entered.argmax(-1), x.shape[-1] - 1)  # (n, N)
    gap = np.take_along_axis(y, first[..., None], -1)[..., 0] - np.take_along_axis(
        np.broadcast_to(other_xy[:, None, :, 1], y.shape), first[..., None], -1)[..., 0]
    changed = (np.abs(x) > half).any(-1)

    out = np.where(envs.goal[:, None] == GOAL_MERGE, OTHER_MERGE, OTHER_FORWARD).astype(np.int8)
    out = np.broadcast_to(out, x.shape[:2]).copy()
    out = np.where(cls == MERGING, np.where(gap > 0, MERGE_AHEAD, MERGE_BEHIND), out)
    out = np.where(cls == BRAKING, np.where(changed, BRAKE_CHANGE, BRAKE_STAY), out)
    out = np.where(cls == TAILGATING, np.where(changed, TAIL_CHANGE, TAIL_STAY), out)
    return out.astype(np.int8)[:, 0] if single else out.astype(np.int8)
