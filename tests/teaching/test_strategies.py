"""Strategy clusters h(xi) on hand-built robot state arrays (DESIGN §2): computed from the trajectory only."""
import math

import numpy as np
import pytest

from teaching.environments import BRAKING, MERGING, OTHER, TAILGATING, environment_id, get_environments
from teaching.strategies import (BRAKE_CHANGE, BRAKE_STAY, CLASS_OF_CLUSTER, MERGE_AHEAD, MERGE_BEHIND,
                                 OTHER_FORWARD, OTHER_MERGE, TAIL_CHANGE, TAIL_STAY, strategy_labels)

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
    assert CLASS_OF_CLUSTER.tolist() == [MERGING, MERGING, BRAKING, BRAKING, TAILGATING, TAILGATING, OTHER, OTHER]


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
    # entry counts at x >= 6 exactly (half a lane towards the right)
    x_edge = np.where(t >= 10, 6.0, 0.0)
    assert label(MERGE_CAR_BEHIND, x_edge, 12.5 * t) == MERGE_AHEAD  # at t = 10: 125 vs 25
    # x = 5.99 is not yet in the lane: never enters, so the gap at T decides (250 vs 150 -> ahead; vs 350 -> behind)
    x_near = np.where(t >= 10, 5.99, 0.0)
    assert label(MERGE_CAR_BEHIND, x_near, 12.5 * t) == MERGE_AHEAD
    assert label(MERGE_CAR_AHEAD, x_near, 12.5 * t) == MERGE_BEHIND


def test_merging_moving_left_is_not_an_entry():
    # the robot swerves left (x = -12) and stays level with nothing: only x >= +6 counts as entering
    x = -np.minimum(t, 12.0)
    y = 12.5 * t
    # never enters: gap at T: robot 250, car 100 behind at 150 -> ahead; car 100 ahead at 350 -> behind
    assert label(MERGE_CAR_BEHIND, x, y) == MERGE_AHEAD
    assert label(MERGE_CAR_AHEAD, x, y) == MERGE_BEHIND


@pytest.mark.parametrize("x_end, expected", [
    (0.0, BRAKE_STAY), (5.9, BRAKE_STAY), (-5.9, BRAKE_STAY), (6.1, BRAKE_CHANGE), (-12.0, BRAKE_CHANGE),
    (12.0, BRAKE_CHANGE)])
def test_braking_stay_or_change_by_leaving_the_centre_lane(x_end, expected):
    x = x_end * np.minimum(t / 8.0, 1.0)
    assert label(BRAKE_ENV, x, 10.0 * t) == expected


def test_braking_change_counts_even_if_the_robot_comes_back():
    x = np.where((t >= 5) & (t <= 12), -12.0, 0.0)  # out to the left and back
    assert label(BRAKE_ENV, x, 12.5 * t) == BRAKE_CHANGE


@pytest.mark.parametrize("x_end, expected", [
    (0.0, TAIL_STAY), (4.0, TAIL_STAY), (-12.0, TAIL_CHANGE), (12.0, TAIL_CHANGE)])
def test_tailgating_change_or_stay(x_end, expected):
    x = x_end * np.minimum(t / 8.0, 1.0)
    assert label(TAIL_ENV, x, 15.0 * t) == expected


def test_other_environments_are_labelled_by_goal_whatever_the_trajectory():
    for x in (np.zeros(T + 1), np.minimum(t, 12.0), -np.minimum(t, 12.0)):
        for y in (5.0 * t, 20.0 * t):
            assert label(OTHER_MERGE_ENV, x, y) == OTHER_MERGE
            assert label(OTHER_FWD_ENV, x, y) == OTHER_FORWARD


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
    assert out.tolist() == [[MERGE_BEHIND, MERGE_BEHIND, MERGE_BEHIND],
                            [BRAKE_STAY, BRAKE_CHANGE, BRAKE_CHANGE],
                            [TAIL_STAY, TAIL_CHANGE, TAIL_CHANGE],
                            [OTHER_FORWARD] * 3]
    # an explicitly given other car is used instead of the environment's: put the merging car far behind
    other = np.zeros((4, T + 1, 2))
    other[..., 1] = -1000.0
    assert strategy_labels(batch, envs, other)[0].tolist() == [MERGE_AHEAD] * 3
    single = strategy_labels(batch[:, 1], envs)
    assert single.shape == (4,)
    np.testing.assert_array_equal(single, out[:, 1])
