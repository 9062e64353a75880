"""Reward features (DESIGN §3) on hand-built trajectories, the normalisers, reward(), and the
planner objective's exact gradient and Hessian against central finite differences."""
import math

import numpy as np
import pytest

from teaching.domains.driving import kernels
from teaching.domains.driving.dynamics import rollout_np
from teaching.domains.driving.environments import environment_id, get_environments, other_car_states
from teaching.domains.driving.features import (
    calibrate_normalisers,
    calibration_controls,
    default_normalisers,
    raw_features,
    reward,
)
from teaching.domains.driving.planner import objective_weights
from teaching.domains.driving.world import THETA_STAR, WORLD

K, T = WORLD.n_knots, WORLD.horizon
Y_MAX = 368.75  # 0.25 * sum_{t<20} (50 + 2.5 t), see test_dynamics


def far_car(n=1):
    xy = np.zeros((n, T + 1, 2))
    xy[..., 1] = 1e6
    return xy


def straight(accel=0.0):
    z = np.zeros((1, K, 2))
    z[..., 1] = accel
    return z


def hand_features(knots, other_xy, goal):
    """Features computed from the rolled-out states with plain NumPy (the test's own reference):
    sigma_lat = 3 ft, sigma_long = 20 ft, turning sum_t sqrt(dh^2 + 0.01^2) - 0.01."""
    s = rollout_np(knots)
    x, y, h, v = s[..., 0], s[..., 1], s[..., 2], s[..., 3]
    dx = x[..., 1:] - other_xy[..., 1:, 0]
    dy = y[..., 1:] - other_xy[..., 1:, 1]
    close = np.exp(-0.5 * (dx**2 / 9.0 + dy**2 / 400.0)).sum(-1)
    acc = (np.diff(v, axis=-1) ** 2).sum(-1)
    dev = ((v[..., 1:] - 50.0) ** 2).sum(-1)
    d = h[..., 1:] - math.pi / 2
    eps = 1e-2
    turn = (np.sqrt(d**2 + eps**2) - eps).sum(-1)
    merge = (np.maximum(0.0, 12.0 - x[..., 1:]) ** 2).sum(-1)
    fwd = Y_MAX - y[..., -1]
    return np.stack([close, acc, dev, turn, np.where(np.asarray(goal) == 0, merge, fwd)], axis=-1)


def test_straight_at_constant_speed():
    f_fwd = raw_features(straight(), far_car(), np.array([1]))[0]
    assert f_fwd[0] == pytest.approx(0.0, abs=1e-300)
    assert f_fwd[1] == 0.0 and f_fwd[2] == 0.0 and f_fwd[3] == 0.0
    assert WORLD.y_reachable_max == pytest.approx(Y_MAX)
    assert f_fwd[4] == pytest.approx(Y_MAX - 250.0, abs=1e-10)  # y_T = 20 * 12.5 = 250
    f_merge = raw_features(straight(), far_car(), np.array([0]))[0]
    np.testing.assert_array_equal(f_merge[:4], f_fwd[:4])
    assert f_merge[4] == pytest.approx(20 * 12.0**2, abs=1e-9)  # x_t = 0 for t = 1..20: (12 - 0)^2 each


def test_full_throttle_gives_the_hand_worked_speed_features():
    f = raw_features(straight(1.0), far_car(), np.array([1]))[0]
    assert f[1] == pytest.approx(20 * 2.5**2)  # each step changes v by 2.5: 125
    assert f[2] == pytest.approx(6.25 * sum(t * t for t in range(1, 21)))  # (2.5 t)^2: 17937.5
    assert f[4] == pytest.approx(0.0, abs=1e-10)  # reaches the furthest y
    g = raw_features(straight(-0.5), far_car(), np.array([1]))[0]
    assert g[1] == pytest.approx(20 * 1.25**2)
    # braking at 5 ft/s^2: y_T = 0.25 * sum (50 - 1.25 t) = 250 - 59.375
    assert g[4] == pytest.approx(Y_MAX - (250.0 - 59.375))


def test_closeness_for_a_car_at_a_known_offset():
    s = rollout_np(straight())  # (1, 21, 5)
    robot = s[..., :2]
    # 3 ft to the side and 10 ft ahead at every step: exp(-1/2 (9/9 + 100/400)) = exp(-5/8) per step
    f = raw_features(straight(), robot + [3.0, 10.0], np.array([1]))[0]
    assert f[0] == pytest.approx(20 * math.exp(-0.625), rel=1e-12)
    # the long axis is along the other car's heading (y): 20 ft ahead costs what 3 ft aside does
    ahead = raw_features(straight(), robot + [0.0, 20.0], np.array([1]))[0, 0]
    aside = raw_features(straight(), robot + [3.0, 0.0], np.array([1]))[0, 0]
    assert ahead == pytest.approx(20 * math.exp(-0.5), rel=1e-12)
    assert aside == pytest.approx(20 * math.exp(-0.5), rel=1e-12)
    across = raw_features(straight(), robot + [12.0, 0.0], np.array([1]))[0, 0]  # level, in the next lane
    assert across == pytest.approx(20 * math.exp(-8.0), rel=1e-9)
    # the sum runs over t = 1..T: a car on top of the robot only at t = 0 adds nothing
    only_start = far_car()
    only_start[0, 0] = [0.0, 0.0]
    assert raw_features(straight(), only_start, np.array([1]))[0, 0] < 1e-300
    only_end = far_car()
    only_end[0, T] = robot[0, T]
    assert raw_features(straight(), only_end, np.array([1]))[0, 0] == pytest.approx(1.0)


def test_closeness_with_a_real_environment_by_hand():
    # forward, other car in the centre lane 100 ft ahead at a constant 20 ft/s; robot straight at 50:
    # the gap closes at 30 ft/s: dy_t = 12.5 t - (100 + 5 t) = 7.5 t - 100
    env = get_environments([environment_id(1, 100, 1, 20)])
    f = raw_features(straight(), other_car_states(env), env.goal)[0]
    want = sum(math.exp(-0.5 * (7.5 * t - 100) ** 2 / 400) for t in range(1, 21))
    assert f[0] == pytest.approx(want, rel=1e-9)


def test_turning_and_merge_cost_on_a_lane_change():
    z = np.zeros((1, K, 2))
    z[0, :4, 0] = [-0.45, 0.45, 0.45, -0.45]  # right lane change (steer right first)
    s = rollout_np(z)[0]
    assert s[-1, 0] > 9  # ends near the right lane
    f = raw_features(z, far_car(), np.array([0]))[0]
    # turning is defined once, everywhere (planner, table, learners): sum_t sqrt(dh^2 + eps^2) - eps
    eps = WORLD.turn_smoothing
    assert eps == 0.01
    assert f[3] == pytest.approx(sum(math.sqrt((s[t, 2] - math.pi / 2) ** 2 + 1e-4) - 0.01
                                     for t in range(1, 21)), rel=1e-12)
    exact = sum(abs(s[t, 2] - math.pi / 2) for t in range(1, 21))
    assert exact - 20 * eps <= f[3] < exact  # within eps per step below |dh|
    assert f[4] == pytest.approx(sum(max(0.0, 12.0 - s[t, 0]) ** 2 for t in range(1, 21)), rel=1e-12)
    assert f[1] == 0.0 and f[2] == 0.0


def test_all_features_on_random_trajectories_match_the_reference_from_states():
    rng = np.random.default_rng(5)
    z = rng.uniform(-1, 1, (64, K, 2))
    env = get_environments(rng.integers(0, 21216, 64))
    oxy = other_car_states(env)
    np.testing.assert_allclose(raw_features(z, oxy, env.goal), hand_features(z, oxy, env.goal),
                               rtol=1e-11, atol=1e-11)


def test_normalisers_closeness_raw_the_rest_from_the_calibration_maximum():
    norm = default_normalisers()
    assert norm.shape == (5,)
    assert norm[0] == 1.0
    assert np.all(norm[1:] > 0)
    # the largest speed features come from constant full acceleration / braking, worked out above
    assert norm[1] == pytest.approx(125.0)
    assert norm[2] == pytest.approx(17937.5)
    # every calibration trajectory scores within [0, 1] on features 2-5 and each maximum is attained
    ctrl = calibration_controls()
    assert len(ctrl) > 9  # the 9 constant-acceleration rows plus the on-road random ones
    raw = np.concatenate([raw_features(ctrl, far_car(len(ctrl)), np.full(len(ctrl), g)) for g in (0, 1)])
    scaled = raw[:, 1:] / norm[1:]
    assert scaled.min() >= 0.0
    np.testing.assert_allclose(scaled.max(axis=0), 1.0, rtol=1e-12)
    # it is a fixed constant: a copy, and the same value as a fresh calibration
    norm[1] = -1.0
    assert default_normalisers()[1] == pytest.approx(125.0)
    np.testing.assert_array_equal(default_normalisers(), calibrate_normalisers())


def test_reward_is_the_dot_product_with_broadcast():
    assert reward(np.array([1.0, 2.0, 3.0, 4.0, 5.0]), np.array([-1.0, -0.5, 0.0, 2.0, 1.0])) == 11.0
    rng = np.random.default_rng(0)
    phi = rng.random((3, 4, 5))
    th = -rng.random((4, 5))
    r = reward(phi, th)
    assert r.shape == (3, 4)
    for m in range(3):
        for n in range(4):
            assert r[m, n] == pytest.approx(sum(phi[m, n, i] * th[n, i] for i in range(5)), rel=1e-14)
    # broadcasting theta*'s trajectory across thetas gives bit-identical numbers to an explicit copy:
    # the exact d_reward >= 0 comparison relies on this
    star = reward(phi[:, :1], th)
    assert star.shape == (3, 4)
    np.testing.assert_array_equal(star, reward(np.repeat(phi[:, :1], 4, axis=1), th))
    np.testing.assert_array_equal(reward(phi, th)[:, 0], star[:, 0])


# --- exact derivatives of the planner objective -------------------------------------------------

def _grad_hess(z, oxy, goal, w):
    g = np.empty(2 * K)
    H = np.empty((2 * K, 2 * K))
    F = kernels.objective_grad_hess(z, np.ascontiguousarray(oxy[:, 0]), np.ascontiguousarray(oxy[:, 1]),
                                    int(goal), w, g, H, True)
    return F, g, H


def _obj(zf, oxy, goal, w):
    return kernels.objective(zf.reshape(K, 2), np.ascontiguousarray(oxy[:, 0]), np.ascontiguousarray(oxy[:, 1]),
                             int(goal), w)


def _central_differences(z, oxy, goal, w, h=1e-5):
    """Gradient from differences of F and Hessian from differences of the exact gradient, (2K,), (2K, 2K)."""
    zf = z.reshape(-1)
    g_fd = np.empty(2 * K)
    H_fd = np.empty((2 * K, 2 * K))
    for j in range(2 * K):
        e = np.zeros(2 * K)
        e[j] = h
        g_fd[j] = (_obj(zf + e, oxy, goal, w) - _obj(zf - e, oxy, goal, w)) / (2 * h)
        H_fd[:, j] = (_grad_hess((zf + e).reshape(K, 2), oxy, goal, w)[1]
                      - _grad_hess((zf - e).reshape(K, 2), oxy, goal, w)[1]) / (2 * h)
    return g_fd, H_fd


def hand_penalties(x, goal, h_end=math.pi / 2):
    """The constraints by hand: |x_t| <= 12 (outer lane centres) at every step, x_T within 2 ft of a
    lane centre (of the right lane's, x = 12, for the merge goal) and h_T within 0.05 rad of straight
    (100 ft per rad); penalty W q^2 for o ft outside (o < 0 inside), q = s log(1 + e^(o/s)), W = 10,
    s = 0.05 ft."""
    def pen(o):
        o = np.asarray(o, float)
        return 10.0 * (0.05 * np.logaddexp(0.0, o / 0.05)) ** 2

    centre = 12.0 if goal == 0 else min((-12.0, 0.0, 12.0), key=lambda c: abs(x[-1] - c))
    return float(np.sum(pen(np.abs(x) - 12.0)) + pen(abs(x[-1] - centre) - 2.0)
                 + pen(100.0 * (abs(h_end - math.pi / 2) - 0.05)))


def test_constraint_penalties_by_hand():
    far = far_car()[0]
    w = np.zeros(5)  # no features: F is the penalties alone
    z = np.zeros((K, 2))
    assert _obj(z.reshape(-1), far, 1, w) < 1e-30  # straight on in the centre lane: allowed (2 ft inside)
    # merge goal: 10 ft short of the band, ~W o^2 (the softplus adds ~s^2 e^(-o/s), nothing here)
    assert _obj(z.reshape(-1), far, 0, w) == pytest.approx(10 * 100.0, rel=1e-12)
    z[:4, 0] = [-0.45, 0.45, 0.45, -0.45]  # right lane change: ends at x = 12.43, 0.43 ft past the limit
    s = rollout_np(z)
    x, h_end = s[1:, 0], s[-1, 2]
    assert 12.0 < x[-1] < 12.5 and abs(h_end - math.pi / 2) < 0.05
    for goal in (0, 1):
        assert _obj(z.reshape(-1), far, goal, w) == pytest.approx(hand_penalties(x, goal, h_end), rel=1e-12)
    z[:4, 0] *= 0.5  # half a lane change: ends between the centre and the right lane
    s = rollout_np(z)
    x, h_end = s[1:, 0], s[-1, 2]
    assert 3.0 < x[-1] < 9.0
    assert hand_penalties(x, 1, h_end) > 1.0
    assert _obj(z.reshape(-1), far, 1, w) == pytest.approx(hand_penalties(x, 1, h_end), rel=1e-12)
    z[-1, 0] = 1.0  # and turns left in the last half second: ends at an angle
    s = rollout_np(z)
    x, h_end = s[1:, 0], s[-1, 2]
    assert h_end - math.pi / 2 > 0.05
    for goal in (0, 1):
        assert _obj(z.reshape(-1), far, goal, w) == pytest.approx(hand_penalties(x, goal, h_end), rel=1e-12)


CASES = {
    # (environment, theta): forward with the other car ahead in the robot's lane and slow (it gets close),
    # merging with the car just behind in the target lane, and a merge with the car two lanes away
    "forward-close": (environment_id(1, 100, 1, 20), THETA_STAR),
    "merge-close": (environment_id(0, -100, 2, 50, 1.0, 70.0), THETA_STAR),
    "merge-far": (environment_id(0, 240, 0, 80), np.array([-10.0, -1.0, -0.3, -0.5, -2.0])),
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("seed", [0, 1])
def test_gradient_and_hessian_match_central_differences(case, seed):
    eid, theta = CASES[case]
    env = get_environments([eid])
    oxy = other_car_states(env)[0]
    goal = int(env.goal[0])
    w = objective_weights(theta, default_normalisers())[0]
    rng = np.random.default_rng(seed)
    z = rng.uniform(-0.6, 0.6, (K, 2))
    steer = rollout_np(z)[:, 4]
    assert np.abs(steer).max() < 0.45  # away from the clip, where F is smooth
    F, g, H = _grad_hess(z, oxy, goal, w)
    # the value: F = w . phi_raw (the stored features) plus the world's constraint penalties
    phi = raw_features(z[None], oxy[None], env.goal)[0]
    s = rollout_np(z)
    assert F == pytest.approx(float(w @ phi) + hand_penalties(s[1:, 0], goal, s[-1, 2]), rel=1e-12)
    assert F == pytest.approx(_obj(z.reshape(-1), oxy, goal, w), rel=1e-13)
    if case.endswith("close"):
        assert phi[0] * w[0] > 1e-3 * abs(float(w @ phi))  # the closeness term really takes part
    g_fd, H_fd = _central_differences(z, oxy, goal, w)
    assert np.linalg.norm(g - g_fd) / np.linalg.norm(g) < 1e-6
    assert np.linalg.norm(H - H_fd) / np.linalg.norm(H) < 1e-6
    np.testing.assert_array_equal(H, H.T)
    # the gradient-only call gives the same value and gradient
    g2 = np.empty(2 * K)
    F2 = kernels.objective_grad_hess(z, np.ascontiguousarray(oxy[:, 0]), np.ascontiguousarray(oxy[:, 1]), goal, w,
                                     g2, np.empty((2 * K, 2 * K)), False)
    assert F2 == F
    np.testing.assert_array_equal(g2, g)


def test_gradient_and_hessian_where_the_steering_clip_binds():
    """Steer fraction 0.9 for 4 knots: the angle would reach 0.54 at t = 6, so it is clipped (strictly) at
    t = 6, 7, 8; the derivatives there treat the clipped angle as constant, which is exact."""
    eid, theta = CASES["merge-close"]
    env = get_environments([eid])
    oxy = other_car_states(env)[0]
    w = objective_weights(theta, default_normalisers())[0]
    z = np.zeros((K, 2))
    z[:4, 0] = 0.9
    z[4:, 0] = -0.5
    z[:, 1] = np.linspace(-0.3, 0.4, K)
    steer = rollout_np(z)[:, 4]
    assert steer.max() == pytest.approx(0.5) and np.sum(np.isclose(steer, 0.5)) == 3
    F, g, H = _grad_hess(z, oxy, 0, w)
    g_fd, H_fd = _central_differences(z, oxy, 0, w)
    assert np.linalg.norm(g - g_fd) / np.linalg.norm(g) < 1e-6
    assert np.linalg.norm(H - H_fd) / np.linalg.norm(H) < 1e-6
