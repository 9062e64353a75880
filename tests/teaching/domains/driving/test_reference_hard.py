"""The hard-constraint reference (teaching/domains/driving/reference_hard.py): its own features equal the
stored ones, its Jacobians are right, it presses against |x| = 12 when the objective wants to leave
the road, and where no limit is active it agrees with the penalised reference."""
import inspect

import numpy as np
import pytest

from teaching.domains.driving import reference, reference_hard
from teaching.domains.driving.environments import environment_id, get_environments, other_car_states
from teaching.domains.driving.features import default_normalisers, raw_features, reward
from teaching.domains.driving.planner import objective_weights, strategy_seeds
from teaching.domains.driving.world import THETA_STAR, WORLD

K, T = WORLD.n_knots, WORLD.horizon


def _random_controls(n, seed=0):
    z = np.random.default_rng(seed).uniform(-1, 1, (n, K, 2))
    z[..., 0] *= 0.3  # full-range random steering spins the car
    return z


def test_features_equal_the_stored_ones():
    envs = get_environments([environment_id(0, 100, 2, 50), environment_id(1, 120, 1, 30),
                             environment_id(1, -140, 1, 70, 1.0, 80), environment_id(0, -200, 0, 20)])
    oxy, z = other_car_states(envs), _random_controls(4)
    stored = raw_features(z, oxy, envs.goal)
    mine = np.array([reference_hard.features_jac(*reference_hard.rollout_jac(z[i]), oxy[i], envs.goal[i])[0]
                     for i in range(4)])
    assert np.abs(mine - stored).max() <= 1e-9 * np.abs(stored).max(axis=0).max()
    assert np.all(np.abs(mine - stored) <= 1e-9 * np.abs(stored) + 1e-15)


def test_jacobians_match_finite_differences():
    env = get_environments([environment_id(0, 100, 2, 50)])
    oxy, z = other_car_states(env)[0], _random_controls(1, seed=3)[0].reshape(-1)
    S, J = reference_hard.rollout_jac(z)
    phi, dphi = reference_hard.features_jac(S, J, oxy, 0)
    g, dg = reference_hard.constraints_jac(S, J, 12.0)
    fd_phi, fd_g = np.zeros_like(dphi), np.zeros_like(dg)
    for j in range(2 * K):
        e = np.zeros(2 * K)
        e[j] = 1e-6
        p, m = reference_hard.rollout_jac(z + e), reference_hard.rollout_jac(z - e)
        fd_phi[:, j] = (reference_hard.features_jac(*p, oxy, 0)[0] - reference_hard.features_jac(*m, oxy, 0)[0]) / 2e-6
        fd_g[:, j] = (reference_hard.constraints_jac(*p, 12.0)[0] - reference_hard.constraints_jac(*m, 12.0)[0]) / 2e-6
    assert np.allclose(dphi, fd_phi, rtol=1e-5, atol=1e-5 * np.abs(dphi).max())
    assert np.allclose(dg, fd_g, rtol=1e-6, atol=1e-6)


def test_its_own_starts_and_no_shared_objective():
    starts = reference_hard.hard_starts()
    assert len(starts) >= 20 and np.abs(starts).max() <= 1.0
    for other in (strategy_seeds(), reference.reference_starts()):
        assert min(np.abs(s - o).max() for s in starts for o in other) > 1e-3
    src = inspect.getsource(reference_hard)
    assert "kernels" not in src and "raw_features" not in src


def test_presses_against_the_road_edge_when_the_objective_wants_to_leave_it():
    """Merge goal, no other car, the goal feature weighted 1000x: the car rushes right, and a fast
    lane change overshoots the right lane's centre unless |x| <= 12 holds exactly."""
    far = np.zeros((T + 1, 2))
    far[:, 1] = 1e6
    theta = np.array([-1e-3, -1e-3, -1e-3, -1e-3, -1.0])
    r = reference_hard.solve_hard(far, 0, theta, default_normalisers(), starts=reference_hard.hard_starts()[:8])
    m = reference_hard.margins(r["z"], 0)
    assert r["violation"] <= 1e-9 and m["violation_ft"] <= 1e-9 and m["violation_rad"] <= 1e-12
    assert m["road_min"] <= 1e-6  # touches |x| = 12 ...
    assert m["road"][-1] < 2.0  # ... and ends in the right lane
    # without the road limit the same objective leaves the road: SLSQP from the answer, with only the
    # lane-end and heading constraints, goes past x = 12 and gains
    loose = _EndOnly(far, 0, reference_hard.hard_weights(theta, default_normalisers()), 12.0)
    z = reference_hard.slsqp(loose, r["z"])
    assert reference_hard.margins(z, 0)["road_min"] < -1e-3 and loose.f(z) < r["f"] - 1e-9


class _EndOnly(reference_hard.HardProblem):
    """The same problem without |x_t| <= 12 (only the last four constraints: lane end, heading)."""

    def g(self, z):
        return super().g(z)[-4:]

    def dg(self, z):
        return super().dg(z)[-4:]


def test_agrees_with_the_penalised_reference_where_no_limit_is_active():
    """Drive forward, the other car far ahead in the left lane: a straight drive, every limit slack."""
    env = get_environments([environment_id(1, 200, 0, 50)])
    oxy, goal, norm = other_car_states(env)[0], int(env.goal[0]), default_normalisers()
    hard = reference_hard.solve_hard(oxy, goal, THETA_STAR, norm, starts=reference_hard.hard_starts()[:6])
    m = reference_hard.margins(hard["z"], goal)
    assert m["road_min"] > 1.0 and m["lane_end"] > 1.0 and m["heading"] > 0.01
    soft = reference.solve_reference(oxy, goal, objective_weights(THETA_STAR, norm)[0],
                                     starts=reference.reference_starts()[:7])
    r_soft = reward(raw_features(soft["z"][None], oxy[None], np.array([goal])) / norm, THETA_STAR)[0]
    r_hard = reward(hard["phi"] / norm, THETA_STAR)
    assert r_hard == pytest.approx(r_soft, abs=1e-7 * np.linalg.norm(THETA_STAR))
    assert np.abs(hard["z"] - soft["z"]).max() < 1e-3
