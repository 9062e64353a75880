"""Strategy clusters h(xi): 8 in all, two per environment class (DESIGN §2), plus
"none" for a trajectory that shows neither strategy of its class.

Computed from the trajectory itself, never from theta.  A car is *in* a lane
when its centre is within a quarter lane (3 ft) of the lane's centre, and has
*left* the centre lane once its centre is more than half a lane (6 ft) from it.
A lane change is *clean* when it is one movement: the car is between lanes (in
none) for at most 2 s, and it never turns back across by more than 3 ft (no
weaving).  Every strategy that changes lane must be clean:

* merging: only a car that merged -- ends in the right lane, never entered the
  left lane -- is "ahead" or "behind": the sign of the y gap to the other car at
  the first step its centre crosses into the right lane (x >= 6 ft);
* braking / tailgating: "stay" if it never leaves the centre lane, "change
  lane" if it ends in another lane;
* other: "merge" for a merge-goal car that merged, "forward" for a
  forward-goal car that never left the centre lane.

Anything else -- a "merge right" car that stops on the lane line or swerves
left, drives along the lane line, weaves, or a lane change that ends between
lanes or comes back -- is NO_STRATEGY and is never shown as an example or a
test option of a cluster (selection skips environments where theta* shows it).
"""
from __future__ import annotations

import numpy as np

from .environments import BRAKING, MERGING, OTHER, TAILGATING, Environments, environment_class, other_car_states
from .world import GOAL_MERGE, WORLD

(MERGE_AHEAD, MERGE_BEHIND, BRAKE_STAY, BRAKE_CHANGE, TAIL_CHANGE, TAIL_STAY, OTHER_MERGE, OTHER_FORWARD,
 NO_STRATEGY) = range(9)
N_CLUSTERS = 8  # the real strategies; NO_STRATEGY is not a cluster
CLUSTER_NAMES = (
    "merging: ahead", "merging: behind",
    "braking: stay in lane", "braking: change lane",
    "tailgating: change lane", "tailgating: stay (speed up)",
    "other: merge", "other: forward",
    "none of its class's strategies",
)
CLASS_OF_CLUSTER = np.array([MERGING, MERGING, BRAKING, BRAKING, TAILGATING, TAILGATING, OTHER, OTHER, -1])
IN_LANE = WORLD.lane_width / 4  # ft from a lane centre: "in" that lane
LEFT_LANE = WORLD.lane_width / 2  # ft from the centre lane's centre: "left" it
MAX_STEPS_BETWEEN_LANES = 8  # 2 s: a lane change here takes 1.5-3 s, half of it between lanes
MAX_TURN_BACK = 3.0  # ft a lane change may come back across (weaving beyond it is not one movement)


def clean_lane_change(x: np.ndarray) -> np.ndarray:
    """(..., T+1) lateral positions (ft) -> (...) bool: between lanes for at most
    MAX_STEPS_BETWEEN_LANES steps and never turning back across by more than MAX_TURN_BACK ft."""
    centres = np.asarray(WORLD.lane_centres)
    between = (np.abs(x[..., None] - centres).min(-1) > IN_LANE).sum(-1)
    back_left = (np.maximum.accumulate(x, axis=-1) - x).max(-1)  # came back left from its rightmost
    back_right = (x - np.minimum.accumulate(x, axis=-1)).max(-1)  # came back right from its leftmost
    return (between <= MAX_STEPS_BETWEEN_LANES) & (np.minimum(back_left, back_right) <= MAX_TURN_BACK)


def lane_crossings(x: np.ndarray) -> np.ndarray:
    """(..., T+1) lateral positions (ft) -> (...) int: how many times the car's centre crosses a lane
    line (one lane change: 1; over two lanes: 2; right, then left across two lanes: 3)."""
    centres = np.asarray(WORLD.lane_centres)
    lines = (centres[1:] + centres[:-1]) / 2
    right_of = x[..., None] > lines  # (..., T+1, lines); on a line is not across it
    return (right_of[..., 1:, :] != right_of[..., :-1, :]).sum((-2, -1))


def strategy_labels(states: np.ndarray, envs: Environments, other_xy: np.ndarray | None = None) -> np.ndarray:
    """Cluster of each trajectory (0..7, or NO_STRATEGY).

    states: (n, N, T+1, 5) robot states of N trajectories in each of the n
    environments (or (n, T+1, 5) for one trajectory each), x in ft.  Returns
    int8 (n, N) (or (n,)).
    """
    single = states.ndim == 3
    if single:
        states = states[:, None]
    if other_xy is None:
        other_xy = other_car_states(envs)
    cls = environment_class(envs)[:, None]
    right = WORLD.lane_centres[2]
    x, y = states[..., 0], states[..., 1]  # (n, N, T+1)

    clean = clean_lane_change(x)
    merged = (np.abs(x[..., -1] - right) <= IN_LANE) & (x.min(-1) >= -LEFT_LANE) & clean
    kept_lane = np.abs(x).max(-1) <= LEFT_LANE
    changed = (np.abs(np.abs(x[..., -1]) - right) <= IN_LANE) & clean  # ends in the left or the right lane

    entered = x >= LEFT_LANE
    first = np.where(entered.any(-1), entered.argmax(-1), x.shape[-1] - 1)  # (n, N)
    gap = np.take_along_axis(y, first[..., None], -1)[..., 0] - np.take_along_axis(
        np.broadcast_to(other_xy[:, None, :, 1], y.shape), first[..., None], -1)[..., 0]

    merge_goal = np.broadcast_to(envs.goal[:, None] == GOAL_MERGE, x.shape[:2])
    out = np.full(x.shape[:2], NO_STRATEGY, np.int8)
    out[(cls == OTHER) & merge_goal & merged] = OTHER_MERGE
    out[(cls == OTHER) & ~merge_goal & kept_lane] = OTHER_FORWARD
    out[(cls == MERGING) & merged & (gap > 0)] = MERGE_AHEAD
    out[(cls == MERGING) & merged & (gap <= 0)] = MERGE_BEHIND
    for c, stay, change in ((BRAKING, BRAKE_STAY, BRAKE_CHANGE), (TAILGATING, TAIL_STAY, TAIL_CHANGE)):
        out[(cls == c) & kept_lane] = stay
        out[(cls == c) & ~kept_lane & changed] = change
    return out[:, 0] if single else out
