"""The 21,216-environment grid: distinctness, stable ids, classes by brute force, other-car motion by hand."""
import itertools

import numpy as np
import pytest

from teaching.domains.driving.environments import (
    BRAKING,
    MERGING,
    N_ENVIRONMENTS,
    OTHER,
    TAILGATING,
    environment_class,
    environment_id,
    get_environments,
    other_car_states,
    stratified_sample,
)

# The grid of DESIGN §2, written out here independently of the module.
GOALS = (0, 1)  # merge right, drive forward
DISTANCES = (-240, -220, -200, -180, -160, -140, -120, -100, 100, 120, 140, 160, 180, 200, 220, 240)
LANES = (0, 1, 2)  # left, centre, right
V0S = tuple(range(20, 81, 5))
PROFILES = ((0.0, None),) + tuple((ta, vf) for ta in (0.5, 1.0, 1.5, 2.0) for vf in (20.0, 30.0, 70.0, 80.0))


def hand_class(goal, distance, lane):
    if lane == 2 and goal == 0:
        return MERGING
    if lane == 1 and goal == 1:
        return BRAKING if distance > 0 else TAILGATING
    return OTHER


@pytest.fixture(scope="module")
def envs():
    return get_environments()


def test_there_are_exactly_21216_distinct_environments(envs):
    assert N_ENVIRONMENTS == 21216 == 2 * 16 * 3 * 13 * 17
    assert len(envs) == 21216
    np.testing.assert_array_equal(envs.ids, np.arange(21216))
    tuples = set(zip(envs.goal.tolist(), envs.other_y0.tolist(), envs.other_lane.tolist(), envs.other_v0.tolist(),
                     envs.accel_time.tolist(), envs.v_final.tolist(), strict=True))
    assert len(tuples) == 21216
    # and they are exactly the hand-written grid (v_f == v0 for a constant-speed car)
    grid = {(g, float(d), lane, float(v), ta, float(v) if vf is None else vf)
            for g, d, lane, v, (ta, vf) in itertools.product(GOALS, DISTANCES, LANES, V0S, PROFILES)}
    assert tuples == grid


def test_environment_id_round_trips_for_every_id(envs):
    for i in range(N_ENVIRONMENTS):
        got = environment_id(int(envs.goal[i]), float(envs.other_y0[i]), int(envs.other_lane[i]),
                             float(envs.other_v0[i]), float(envs.accel_time[i]), float(envs.v_final[i]))
        assert got == i
    # a sub-batch gives the same rows as the full grid
    ids = np.array([21215, 0, 7, 13000])
    sub = get_environments(ids)
    for f in ("goal", "other_y0", "other_lane", "other_v0", "accel_time", "v_final"):
        np.testing.assert_array_equal(getattr(sub, f), getattr(envs, f)[ids])


def test_ids_follow_the_documented_mixed_radix_order():
    # goal, distance, lane, v0, profile; first axis most significant
    assert environment_id(0, -240, 0, 20) == 0
    assert environment_id(0, -240, 0, 20, 0.5, 20.0) == 1
    assert environment_id(0, -240, 0, 25) == 17
    assert environment_id(0, -240, 1, 20) == 13 * 17
    assert environment_id(0, -220, 0, 20) == 3 * 13 * 17
    assert environment_id(1, -240, 0, 20) == 16 * 3 * 13 * 17
    # forward, +100 (distance index 8), centre, 50 ft/s (index 6), t_a = 1 s to 70 ft/s (profile 1 + 4 + 2)
    assert environment_id(1, 100, 1, 50, 1.0, 70.0) == (((1 * 16 + 8) * 3 + 1) * 13 + 6) * 17 + 7
    assert environment_id(1, 240, 2, 80, 2.0, 80.0) == 21215
    last = get_environments([21215])
    assert (last.goal[0], last.other_y0[0], last.other_lane[0], last.other_v0[0], last.accel_time[0],
            last.v_final[0]) == (1, 240.0, 2, 80.0, 2.0, 80.0)
    # constant speed: v_final is ignored by environment_id and reported as v0
    assert environment_id(0, 100, 2, 35, 0.0, 999.0) == environment_id(0, 100, 2, 35)
    assert get_environments([environment_id(0, 100, 2, 35)]).v_final[0] == 35.0


def test_class_sizes_by_brute_force_over_the_grid(envs):
    counts = {MERGING: 0, BRAKING: 0, TAILGATING: 0, OTHER: 0}
    cls = environment_class(envs)
    for g, d, lane, v, (ta, vf) in itertools.product(GOALS, DISTANCES, LANES, V0S, PROFILES):
        c = hand_class(g, d, lane)
        counts[c] += 1
        assert cls[environment_id(g, d, lane, v, ta, vf)] == c
    assert counts == {MERGING: 3536, BRAKING: 1768, TAILGATING: 1768, OTHER: 14144}
    assert np.bincount(cls, minlength=4).tolist() == [3536, 1768, 1768, 14144]
    np.testing.assert_array_equal(envs.env_class, cls)


def test_other_car_speed_ramps_then_holds_by_hand():
    ids = [environment_id(1, 100, 1, 40, 1.0, 80.0),  # speeds up 40 -> 80 over 1 s
           environment_id(0, -120, 2, 80, 2.0, 20.0),  # slows 80 -> 20 over 2 s
           environment_id(1, 240, 0, 35)]  # constant 35
    xy = other_car_states(get_environments(ids))
    assert xy.shape == (3, 21, 2)
    t = np.arange(21) * 0.25
    # 1) y = 100 + 40 t + 20 t^2 for t <= 1 (accel 40 ft/s^2); 100 + 60 + 80 (t - 1) after
    y1 = np.where(t <= 1, 100 + 40 * t + 20 * t**2, 160 + 80 * (t - 1))
    np.testing.assert_allclose(xy[0, :, 1], y1, atol=1e-9)
    assert xy[0, 4, 1] == pytest.approx(160.0) and xy[0, 20, 1] == pytest.approx(480.0)
    # 2) accel -30: y = -120 + 80 t - 15 t^2 for t <= 2 (reaches -20 at t = 2); then + 20 (t - 2)
    y2 = np.where(t <= 2, -120 + 80 * t - 15 * t**2, -20 + 20 * (t - 2))
    np.testing.assert_allclose(xy[1, :, 1], y2, atol=1e-9)
    assert xy[1, 20, 1] == pytest.approx(40.0)
    # 3) constant speed
    np.testing.assert_allclose(xy[2, :, 1], 240 + 35 * t, atol=1e-9)
    # the car stays at its lane centre
    np.testing.assert_array_equal(xy[:, :, 0], [[0.0] * 21, [12.0] * 21, [-12.0] * 21])


def test_other_car_position_is_the_exact_integral_of_its_speed_everywhere(envs):
    """Brute force over all 21,216: the speed is piecewise linear with its kink on the 0.25 s grid
    (t_a is a multiple of 0.25), so the trapezoid rule on that grid is exact."""
    xy = other_car_states(envs)
    t = np.arange(21) * 0.25
    ta = envs.accel_time[:, None]
    frac = np.where(ta > 0, np.minimum(t, ta) / np.where(ta > 0, ta, 1.0), 0.0)
    speed = envs.other_v0[:, None] + (envs.v_final - envs.other_v0)[:, None] * frac
    y = envs.other_y0[:, None] + np.concatenate(
        [np.zeros((len(envs), 1)), np.cumsum(0.25 * (speed[:, 1:] + speed[:, :-1]) / 2, axis=1)], axis=1)
    np.testing.assert_allclose(xy[..., 1], y, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(xy[:, 0, 1], envs.other_y0)


def test_stratified_sample_covers_every_class_equally_and_is_seeded():
    a = stratified_sample(40, seed=3)
    assert len(a) == 40 and len(np.unique(a)) == 40 and np.all(np.diff(a) > 0)
    assert np.bincount(environment_class(get_environments(a)), minlength=4).tolist() == [10, 10, 10, 10]
    np.testing.assert_array_equal(a, stratified_sample(40, seed=3))
    assert not np.array_equal(a, stratified_sample(40, seed=4))
    four = stratified_sample(4, seed=0)
    assert sorted(environment_class(get_environments(four)).tolist()) == [0, 1, 2, 3]
    # an uneven n still gives every class a share and exactly n ids
    seven = stratified_sample(7, seed=1)
    assert len(np.unique(seven)) == 7
    assert set(environment_class(get_environments(seven)).tolist()) == {0, 1, 2, 3}


@pytest.mark.parametrize("n", [0, 3, 21217])
def test_stratified_sample_rejects_bad_sizes(n):
    with pytest.raises(ValueError):
        stratified_sample(n)


@pytest.mark.parametrize("ids", [[-1], [21216], [0, 5, 10**6], [[0, 1]]])
def test_bad_ids_are_rejected(ids):
    with pytest.raises(ValueError):
        get_environments(np.array(ids))


@pytest.mark.parametrize("args", [
    (0, 90, 0, 20), (0, 0, 0, 20), (0, -100, 0, 22), (0, -100, 0, 85), (2, -100, 0, 20), (0, -100, 3, 20),
    (1, 100, 1, 50, 0.7, 20.0), (1, 100, 1, 50, 1.0, 50.0), (1, 100, 1, 50, 1.0, None),
])
def test_environment_id_rejects_parameters_off_the_grid(args):
    with pytest.raises(ValueError, match="no such environment"):
        environment_id(*args)
