"""Strategy clusters h(xi) on hand-built robot state arrays (DESIGN §2): computed from the trajectory only,
and honest: a label names a strategy only when the trajectory shows it."""
import math

import numpy as np
import pytest

from teaching.domains.driving.environments import BRAKING, MERGING, OTHER, TAILGATING, environment_id, get_environments
from teaching.domains.driving.strategies import (
    BRAKE_CHANGE,
    BRAKE_STAY,
    CLASS_OF_CLUSTER,
    CLUSTER_NAMES,
    MERGE_AHEAD,
    MERGE_BEHIND,
    N_CLUSTERS,
    NO_STRATEGY,
    OTHER_FORWARD,
    OTHER_MERGE,
    TAIL_CHANGE,
    TAIL_STAY,
    strategy_labels,
)

T = 20
t = np.arange(T + 1)

# constant-speed other cars (other car y_t = y0 + v0 * 0.25 t)
MERGE_CAR_AHEAD = environment_id(0, 100, 2, 50)  # right lane, 100 ft ahead at 50 ft/s: y = 100 + 12.5 t
MERGE_CAR_BEHIND = environment_id(0, -100, 2, 50)  # y = -100 + 12.5 t
BRAKE_ENV = environment_id(1, 100, 1, 20)  # centre lane ahead, slow
TAIL_ENV = environment_id(1, -100, 1, 80)  # centre lane behind, fast
OTHER_MERGE_ENV = environment_id(0, 100, 0, 50)  # merge, car in the left lane
OTHER_FWD_ENV = environment_id(1, -100, 2, 50)  # forward, car in the right lane


def states(x, y):
    """A hand-built (T+1, 5) robot state array: given x_t and y_t, heading pi/2, speed 50, no steering."""
    s = np.zeros((T + 1, 5))
    s[:, 0] = x
    s[:, 1] = y
    s[:, 2] = math.pi / 2
    s[:, 3] = 50.0
    return s


def label(env_id, x, y):
    return int(strategy_labels(states(x, y)[None], get_environments([env_id]))[0])


def test_the_hand_environments_are_in_the_intended_classes():
    assert get_environments([MERGE_CAR_AHEAD, MERGE_CAR_BEHIND, BRAKE_ENV, TAIL_ENV, OTHER_MERGE_ENV,
                             OTHER_FWD_ENV]).env_class.tolist() == [MERGING, MERGING, BRAKING, TAILGATING, OTHER,
                                                                    OTHER]
    assert CLASS_OF_CLUSTER[:N_CLUSTERS].tolist() == [MERGING, MERGING, BRAKING, BRAKING, TAILGATING, TAILGATING,
                                                      OTHER, OTHER]
    assert NO_STRATEGY == N_CLUSTERS and CLASS_OF_CLUSTER[NO_STRATEGY] == -1 and len(CLUSTER_NAMES) == 9


def test_merging_ahead_or_behind_by_the_gap_when_entering_the_right_lane():
    x = np.minimum(t, 12.0)  # x passes 6 (half a lane) at t = 6
    y = 20.0 * t  # y_6 = 120
    # car 100 behind: at t = 6 it is at -100 + 75 = -25 -> gap +145 -> ahead
    assert label(MERGE_CAR_BEHIND, x, y) == MERGE_AHEAD
    # car 100 ahead: at t = 6 it is at 175 -> gap -55 -> behind
    assert label(MERGE_CAR_AHEAD, x, y) == MERGE_BEHIND
    # a slow robot behind a car that started behind it: at t = 6 robot y = 30, car at -25 -> ahead (gap +55)
    assert label(MERGE_CAR_BEHIND, x, 5.0 * t) == MERGE_AHEAD
    # same slow robot, entering later (t = 16: robot 80, car 100) -> behind
    assert label(MERGE_CAR_BEHIND, np.clip(t - 10, 0, 12.0), 5.0 * t) == MERGE_BEHIND


def test_merging_uses_the_first_entry_not_the_end():
    # enters at t = 3 with y = 60 while the car (ahead start) is at 137.5 -> behind, although the robot
    # overtakes it later (y_T = 791 > 350)
    y = np.where(t <= 3, 20.0 * t, 60.0 + 43.0 * (t - 3))
    x = np.minimum(2.0 * t, 12.0)
    assert x[2] < 6 <= x[3]
    assert y[-1] > 100 + 12.5 * 20
    assert label(MERGE_CAR_AHEAD, x, y) == MERGE_BEHIND
    # entry counts at x >= 6 exactly (half a lane towards the right); at t = 10: robot 125 vs car 25
    x_edge = np.where(t >= 10, 6.0, 0.0)
    x_edge[-3:] = 12.0
    assert label(MERGE_CAR_BEHIND, x_edge, 12.5 * t) == MERGE_AHEAD


@pytest.mark.parametrize("x_end", [9.0, 10.5, 12.0])
def test_a_car_that_ends_in_the_right_lane_merged(x_end):
    x = x_end * np.minimum(t / 8.0, 1.0)
    assert label(MERGE_CAR_BEHIND, x, 12.5 * t) == MERGE_AHEAD
    assert label(OTHER_MERGE_ENV, x, 12.5 * t) == OTHER_MERGE


def test_merge_right_car_that_approaches_the_lane_line_and_swerves_back_left_did_not_merge():
    # the case: drifts to the lane line (x = 6), then swerves back left and ends at x = -10
    x = np.interp(t, [0, 8, 12, 20], [0.0, 6.0, 6.0, -10.0])
    assert x.max() >= 6.0  # it did cross into the right lane's half: the old labeller called this a merge
    for env in (MERGE_CAR_AHEAD, MERGE_CAR_BEHIND, OTHER_MERGE_ENV):
        assert label(env, x, 12.5 * t) == NO_STRATEGY


@pytest.mark.parametrize("x_path", [
    [0.0, 0.0, 0.0, 0.0],  # never moves: the goal not reached
    [0.0, 4.0, 8.0, 8.5],  # stops on the lane line
    [0.0, 6.0, 6.0, 7.0],  # straddles the line to the end
    [0.0, -12.0, -12.0, -12.0],  # dodges into the left lane
    [0.0, -7.0, 6.0, 12.0],  # ends in the right lane, but entered the left lane on the way
    [0.0, 12.0, 12.0, 2.0],  # merged, then came back to the centre lane
])
def test_merge_right_without_ending_in_the_right_lane_is_no_strategy(x_path):
    x = np.interp(t, [0, 6, 12, 20], x_path)
    for env in (MERGE_CAR_AHEAD, MERGE_CAR_BEHIND, OTHER_MERGE_ENV):
        assert label(env, x, 12.5 * t) == NO_STRATEGY


def test_a_merge_along_the_lane_line_or_weaving_is_no_strategy():
    # drives on the lane line (x = 6) for 3 s before completing the merge: 12 steps between lanes
    along_line = np.interp(t, [0, 3, 15, 18, 20], [0.0, 6.0, 6.0, 12.0, 12.0])
    # merges, comes back to the centre lane while the other car passes, merges again at the end
    weave = np.interp(t, [0, 4, 8, 12, 16, 20], [0.0, 12.0, 12.0, 1.0, 12.0, 12.0])
    # the clean version of each: one movement, 1.5 s between lanes
    clean = np.interp(t, [0, 3, 9, 20], [0.0, 0.0, 12.0, 12.0])
    for env in (MERGE_CAR_AHEAD, MERGE_CAR_BEHIND, OTHER_MERGE_ENV):
        assert label(env, along_line, 12.5 * t) == NO_STRATEGY
        assert label(env, weave, 12.5 * t) == NO_STRATEGY
        assert label(env, clean, 12.5 * t) != NO_STRATEGY
    # the limits: 8 steps between lanes is one movement, 9 is not; turning back 3 ft is, 3.5 ft is not
    eight = np.interp(t, [0, 2, 11, 20], [0.0, 3.0, 9.0, 12.0])
    nine = np.interp(t, [0, 2, 12, 20], [0.0, 3.0, 9.0, 12.0])
    assert ((np.abs(eight[:, None] - [-12, 0, 12]).min(1) > 3).sum(),
            (np.abs(nine[:, None] - [-12, 0, 12]).min(1) > 3).sum()) == (8, 9)
    assert label(BRAKE_ENV, eight, 12.5 * t) == BRAKE_CHANGE
    assert label(BRAKE_ENV, nine, 12.5 * t) == NO_STRATEGY
    overshoot = np.interp(t, [0, 6, 10, 20], [0.0, -12.0, -9.0, -9.0])  # left, then 3 ft back: still a change
    assert label(TAIL_ENV, overshoot, 12.5 * t) == TAIL_CHANGE
    assert label(TAIL_ENV, np.interp(t, [0, 6, 10, 20], [0.0, -12.5, -9.0, -9.0]), 12.5 * t) == NO_STRATEGY


@pytest.mark.parametrize("x_end, expected", [
    (0.0, BRAKE_STAY), (5.9, BRAKE_STAY), (-5.9, BRAKE_STAY), (-12.0, BRAKE_CHANGE), (12.0, BRAKE_CHANGE),
    (9.0, BRAKE_CHANGE), (-9.0, BRAKE_CHANGE), (6.1, NO_STRATEGY), (8.9, NO_STRATEGY), (-7.5, NO_STRATEGY)])
def test_braking_stay_in_lane_or_change_into_another_lane(x_end, expected):
    x = x_end * np.minimum(t / 8.0, 1.0)
    assert label(BRAKE_ENV, x, 10.0 * t) == expected


def test_a_lane_change_that_comes_back_is_no_strategy():
    x = np.where((t >= 5) & (t <= 12), -12.0, 0.0)  # out to the left and back: neither stays nor changes
    assert label(BRAKE_ENV, x, 12.5 * t) == NO_STRATEGY
    assert label(TAIL_ENV, x, 12.5 * t) == NO_STRATEGY


@pytest.mark.parametrize("x_end, expected", [
    (0.0, TAIL_STAY), (4.0, TAIL_STAY), (-12.0, TAIL_CHANGE), (12.0, TAIL_CHANGE), (-15.5, NO_STRATEGY),
    (7.0, NO_STRATEGY)])
def test_tailgating_change_or_stay(x_end, expected):
    x = x_end * np.minimum(t / 8.0, 1.0)
    assert label(TAIL_ENV, x, 15.0 * t) == expected


def test_other_environments_merge_only_if_merged_and_forward_only_if_in_lane():
    for y in (5.0 * t, 20.0 * t):
        assert label(OTHER_MERGE_ENV, np.minimum(t, 12.0), y) == OTHER_MERGE
        assert label(OTHER_FWD_ENV, np.zeros(T + 1), y) == OTHER_FORWARD
        assert label(OTHER_FWD_ENV, 0.5 * np.sin(t), y) == OTHER_FORWARD  # wobbles within its lane
        assert label(OTHER_MERGE_ENV, np.zeros(T + 1), y) == NO_STRATEGY
        assert label(OTHER_MERGE_ENV, -np.minimum(t, 12.0), y) == NO_STRATEGY
        assert label(OTHER_FWD_ENV, np.minimum(t, 12.0), y) == NO_STRATEGY
        assert label(OTHER_FWD_ENV, -np.minimum(t, 12.0), y) == NO_STRATEGY


def test_batched_labels_match_one_at_a_time_and_use_the_given_other_car():
    ids = [MERGE_CAR_AHEAD, BRAKE_ENV, TAIL_ENV, OTHER_FWD_ENV]
    envs = get_environments(ids)
    trajs = [states(np.zeros(T + 1), 12.5 * t), states(np.minimum(t, 12.0), 20.0 * t),
             states(-np.minimum(t, 12.0), 5.0 * t)]
    batch = np.stack([np.stack(trajs)] * 4)  # (4 envs, 3 trajectories, T+1, 5)
    out = strategy_labels(batch, envs)
    assert out.shape == (4, 3) and out.dtype == np.int8
    for m, eid in enumerate(ids):
        for n, s in enumerate(trajs):
            assert out[m, n] == label(eid, s[:, 0], s[:, 1])
    assert out.tolist() == [[NO_STRATEGY, MERGE_BEHIND, NO_STRATEGY],
                            [BRAKE_STAY, BRAKE_CHANGE, BRAKE_CHANGE],
                            [TAIL_STAY, TAIL_CHANGE, TAIL_CHANGE],
                            [OTHER_FORWARD, NO_STRATEGY, NO_STRATEGY]]
    # an explicitly given other car is used instead of the environment's: put the merging car far behind
    other = np.zeros((4, T + 1, 2))
    other[..., 1] = -1000.0
    assert strategy_labels(batch, envs, other)[0].tolist() == [NO_STRATEGY, MERGE_AHEAD, NO_STRATEGY]
    single = strategy_labels(batch[:, 1], envs)
    assert single.shape == (4,)
    np.testing.assert_array_equal(single, out[:, 1])
