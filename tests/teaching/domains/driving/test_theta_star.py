"""What participants see: theta*'s trajectories in a real built table (the `demo` preset, every
environment) do what their class says (paper, "Example Domain").

The checks read positions off the stored controls with their own thresholds, not the strategy
labeller's: "in a lane" = the car's centre within 3 ft (a quarter lane) of a lane centre.
"""
import numpy as np
import pytest

from teaching.core.table import TrajectoryTable
from teaching.domains.driving.environments import BRAKING, MERGING, OTHER, TAILGATING, get_environments
from teaching.domains.driving.strategies import (
    BRAKE_CHANGE,
    BRAKE_STAY,
    CLASS_OF_CLUSTER,
    MERGE_AHEAD,
    MERGE_BEHIND,
    NO_STRATEGY,
    TAIL_CHANGE,
    TAIL_STAY,
)

pytestmark = pytest.mark.slow
LANES = np.array([-12.0, 0.0, 12.0])


@pytest.fixture(scope="module")
def star(demo_table):
    """theta*'s states (M, T+1, 5), environment classes and goals, and labels, from the demo table."""
    table = TrajectoryTable.load(demo_table)
    envs = get_environments(table.env_ids)
    return table.states(slice(None), 0), table.env_class, envs.goal, np.asarray(table.strategy[:, 0])


def test_merge_right_always_ends_in_the_right_lane(star):
    states, _, goal, _ = star
    x = states[goal == 0, :, 0]
    assert len(x) > 400  # 442 of the 1,200
    ends_right = np.abs(x[:, -1] - 12.0) <= 3.0
    never_left = x.min(axis=1) > -6.0
    assert ends_right.all(), np.flatnonzero(~ends_right)
    assert never_left.all()


def test_theta_star_stays_between_the_outer_lane_centres_and_ends_straight(star):
    states = star[0]
    assert np.abs(states[..., 0]).max() <= 13.5
    assert np.abs(states[:, -1, 2] - np.pi / 2).max() <= 0.06  # ends driving along its lane


def test_lane_changes_end_at_a_lane_centre(star):
    states, _, goal, _ = star
    x = states[..., 0]
    changed = np.abs(x).max(axis=1) > 6.0  # left the centre lane
    to_centre = np.abs(x[changed, -1][:, None] - LANES).min(axis=1)
    assert changed.sum() > 300
    assert np.mean(to_centre <= 3.0) >= 0.95
    forward = changed & (goal == 1)
    assert forward.sum() > 30  # the braking and tailgating lane changes are among them


def test_other_environments_keep_their_lane_or_merge(star):
    states, cls, goal, _ = star
    x = states[..., 0]
    other = cls == OTHER
    keep = np.abs(x).max(axis=1) <= 6.0
    merged = (np.abs(x[:, -1] - 12.0) <= 3.0) & (x.min(axis=1) > -6.0)
    assert np.mean(keep[other & (goal == 1)]) >= 0.99
    assert np.mean(merged[other & (goal == 0)]) >= 0.99


@pytest.mark.parametrize("cls, pair", [(MERGING, (MERGE_AHEAD, MERGE_BEHIND)), (BRAKING, (BRAKE_STAY, BRAKE_CHANGE)),
                                       (TAILGATING, (TAIL_CHANGE, TAIL_STAY))])
def test_both_strategies_of_each_informative_class_in_at_least_5_percent(star, cls, pair):
    _, classes, _, labels = star
    mine = labels[classes == cls]
    # theta* shows one of its class's strategies, or rarely none (e.g. a merge along the lane line: never shown)
    assert np.all((CLASS_OF_CLUSTER[mine] == cls) | (mine == NO_STRATEGY))
    assert np.mean(mine == NO_STRATEGY) <= 0.10
    for c in pair:
        assert np.mean(mine == c) >= 0.05, (c, np.bincount(mine, minlength=9).tolist())
