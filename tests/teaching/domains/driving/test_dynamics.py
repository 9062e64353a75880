"""Explicit-Euler bicycle rollout (teaching.domains.driving.dynamics / kernels.rollout_one) against hand integration.

Every expected number below is worked out in the test itself (plain arithmetic
or math.cos/sin/tan), never with the kernels.
"""
import math

import numpy as np
import pytest

from teaching.domains.driving.dynamics import HEADING, STEER, V, X, Y, physical_controls, rollout_np
from teaching.domains.driving.world import WORLD

DT = 0.25
L = 9.0
T = 20
K = 10
W_MAX = 0.4  # rad/s
A_MAX = 10.0  # ft/s^2
S_MAX = 0.5  # rad


def test_world_constants_are_the_ones_worked_by_hand_here():
    # the hand computations below rely on these values (DESIGN §2 + world.py)
    assert (WORLD.dt, WORLD.wheelbase, WORLD.horizon, WORLD.n_knots) == (DT, L, T, K)
    assert (WORLD.steer_rate_max, WORLD.accel_max, WORLD.steer_max, WORLD.v_init) == (W_MAX, A_MAX, S_MAX, 50.0)
    np.testing.assert_array_equal(WORLD.control_bounds, [W_MAX, A_MAX])
    # furthest y_T at full throttle, explicit Euler: 0.25 * sum_{t<20} (50 + 2.5 t) = 0.25 * (1000 + 475)
    assert WORLD.y_reachable_max == pytest.approx(368.75, abs=1e-12)


def test_zero_controls_drive_straight_at_50():
    s = rollout_np(np.zeros((K, 2)))
    assert s.shape == (T + 1, 5)
    t = np.arange(T + 1)
    np.testing.assert_allclose(s[:, Y], 12.5 * t, atol=1e-12)  # 50 ft/s * 0.25 s per step
    np.testing.assert_allclose(s[:, X], 0.0, atol=1e-12)
    np.testing.assert_array_equal(s[:, HEADING], math.pi / 2)
    np.testing.assert_array_equal(s[:, V], 50.0)
    np.testing.assert_array_equal(s[:, STEER], 0.0)


@pytest.mark.parametrize("frac", [1.0, -0.4, 0.3])
def test_constant_acceleration_straight_matches_hand_euler(frac):
    z = np.zeros((K, 2))
    z[:, 1] = frac
    s = rollout_np(z)
    a = A_MAX * frac
    for t in range(T + 1):
        v_t = 50.0 + a * DT * t
        # Euler: y_{t+1} = y_t + dt v_t, so y_t = dt * sum_{s<t} v_s = dt * (50 t + a dt t (t-1) / 2)
        y_t = DT * (50.0 * t + a * DT * t * (t - 1) / 2)
        assert s[t, V] == pytest.approx(v_t, abs=1e-12)
        assert s[t, Y] == pytest.approx(y_t, abs=1e-10)
    # full throttle ends exactly at the furthest reachable y
    if frac == 1.0:
        assert s[T, Y] == pytest.approx(WORLD.y_reachable_max, abs=1e-10)


def test_constant_steer_rate_first_steps_by_hand():
    """Knot 0 = (0.5, 0.2) for steps 0-1, knot 1 = (-1, -0.3) for steps 2-3, worked step by step."""
    z = np.zeros((K, 2))
    z[0] = [0.5, 0.2]
    z[1] = [-1.0, -0.3]
    s = rollout_np(z)

    # step 0 -> 1: the state update uses the *old* heading, speed and steer
    x0, y0, h0, v0, st0 = 0.0, 0.0, math.pi / 2, 50.0, 0.0
    x1 = x0 + DT * v0 * math.cos(h0)
    y1 = y0 + DT * v0 * math.sin(h0)  # 12.5
    h1 = h0 + DT / L * v0 * math.tan(st0)  # tan 0 = 0: heading unchanged
    v1 = v0 + DT * A_MAX * 0.2  # 50.5
    st1 = st0 + DT * W_MAX * 0.5  # 0.05
    # step 1 -> 2 (same knot)
    x2 = x1 + DT * v1 * math.cos(h1)
    y2 = y1 + DT * v1 * math.sin(h1)  # 12.5 + 12.625
    h2 = h1 + DT / L * v1 * math.tan(st1)
    v2 = v1 + DT * A_MAX * 0.2  # 51
    st2 = st1 + DT * W_MAX * 0.5  # 0.1
    # step 2 -> 3 (knot 1)
    x3 = x2 + DT * v2 * math.cos(h2)
    y3 = y2 + DT * v2 * math.sin(h2)
    h3 = h2 + DT / L * v2 * math.tan(st2)
    v3 = v2 + DT * A_MAX * -0.3  # 50.25
    st3 = st2 + DT * W_MAX * -1.0  # 0.0
    # step 3 -> 4
    x4 = x3 + DT * v3 * math.cos(h3)
    y4 = y3 + DT * v3 * math.sin(h3)
    h4 = h3 + DT / L * v3 * math.tan(st3)
    v4 = v3 + DT * A_MAX * -0.3
    st4 = st3 + DT * W_MAX * -1.0

    expected = [[x0, y0, h0, v0, st0], [x1, y1, h1, v1, st1], [x2, y2, h2, v2, st2],
                [x3, y3, h3, v3, st3], [x4, y4, h4, v4, st4]]
    np.testing.assert_allclose(s[:5], expected, rtol=0, atol=1e-12)
    # a few of the numbers written out in full
    assert (y1, v1, st1, v2, st2, v3, v4) == pytest.approx((12.5, 50.5, 0.05, 51.0, 0.1, 50.25, 49.5), abs=1e-12)
    assert h2 == pytest.approx(math.pi / 2 + 0.25 / 9 * 50.5 * math.tan(0.05), abs=1e-15)
    # steering left of zero turns the heading to larger angles, i.e. towards -x (left)
    assert h3 > h2 > h1 and x4 < 0


def test_full_braking_for_five_seconds_never_goes_below_zero_speed():
    z = np.zeros((K, 2))
    z[:, 1] = -1.0
    s = rollout_np(z)
    v = s[:, V]
    # v_t = 50 - 2.5 t: exactly 0 at t = 20 (the bounds are chosen so that braking cannot reverse)
    np.testing.assert_allclose(v, 50.0 - 2.5 * np.arange(T + 1), atol=1e-12)
    assert v.min() >= 0.0
    assert np.all(np.diff(s[:, Y]) >= 0)  # never drives backwards
    # and random bounded controls never give a negative speed either
    rng = np.random.default_rng(0)
    assert rollout_np(rng.uniform(-1, 1, (500, K, 2)))[..., V].min() >= 0.0


def test_steering_angle_is_clipped_and_does_not_wind_up():
    z = np.zeros((K, 2))
    z[:5, 0] = 1.0  # steps 0-9 at +0.4 rad/s: +0.1 rad per step
    z[5:, 0] = -1.0  # steps 10-19 at -0.4 rad/s
    st = rollout_np(z)[:, STEER]
    expected = []
    cur = 0.0
    for t in range(T):
        expected.append(cur)
        cur = min(max(cur + (0.1 if t < 10 else -0.1), -S_MAX), S_MAX)
    expected.append(cur)
    np.testing.assert_allclose(st, expected, atol=1e-12)
    # written out: 0.1 t up to the clip at t = 5, held at 0.5 to t = 10, then down at once (no wind-up)
    np.testing.assert_allclose(st[:6], [0, 0.1, 0.2, 0.3, 0.4, 0.5], atol=1e-12)
    np.testing.assert_allclose(st[5:11], 0.5, atol=1e-12)
    assert st[11] == pytest.approx(0.4, abs=1e-12)
    assert st[20] == pytest.approx(-0.5, abs=1e-12)  # 0.5 - 10 * 0.1, clipped from -0.5 exactly
    assert np.abs(st).max() <= S_MAX + 1e-15
    # the same on the other side
    np.testing.assert_allclose(rollout_np(-z)[:, STEER], -np.array(expected), atol=1e-12)


def test_batched_rollout_equals_one_at_a_time():
    rng = np.random.default_rng(1)
    z = rng.uniform(-1, 1, (3, 4, K, 2))
    s = rollout_np(z)
    assert s.shape == (3, 4, T + 1, 5)
    for i in range(3):
        for j in range(4):
            np.testing.assert_array_equal(s[i, j], rollout_np(z[i, j]))
    assert rollout_np(np.zeros((0, K, 2))).shape == (0, T + 1, 5)


@pytest.mark.parametrize("shape", [(K - 1, 2), (K, 3), (K,), (2, K + 1, 2), (2 * K,)])
def test_rollout_rejects_wrong_shapes(shape):
    with pytest.raises(ValueError, match="knots must have shape"):
        rollout_np(np.zeros(shape))


def test_physical_controls_scale_and_hold_each_knot_for_two_steps():
    z = np.zeros((K, 2))
    z[0] = [0.5, -1.0]
    z[3] = [-0.25, 0.5]
    u = physical_controls(z)
    assert u.shape == (T, 2)
    np.testing.assert_allclose(u[0], [0.2, -10.0])
    np.testing.assert_allclose(u[1], [0.2, -10.0])
    np.testing.assert_allclose(u[6], [-0.1, 5.0])
    np.testing.assert_allclose(u[7], [-0.1, 5.0])
    np.testing.assert_array_equal(u[2], [0.0, 0.0])
