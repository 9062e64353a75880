"""The planner's hard-limit solve (teaching/constrained.py, issue 22): the augmented Lagrangian's and
the Lagrangian's terms have exact derivatives; from the soft penalty's answer it reaches the optimum
that the independent hard-constraint reference (teaching/reference_hard.py: its own rollout, starts and
SLSQP) finds, where the penalty's answer falls short; and a chunk planned with `exact=True` is never
worse than the penalised one, feasible to the stored precision."""
import numpy as np
import pytest

from teaching import constrained, kernels, reference_hard
from teaching.candidates import sample_thetas
from teaching.environments import environment_id, get_environments
from teaching.features import default_normalisers, raw_features, reward
from teaching.planner import (
    STORED_FEAS_TOL,
    PlannerSettings,
    limit_excess,
    objective_weights,
    plan_chunk,
    strategy_seeds,
)
from teaching.world import WORLD

K, T, NC = WORLD.n_knots, WORLD.horizon, kernels.NC
FAR = np.stack([np.zeros(T + 1), np.full(T + 1, 1e6)], axis=1)  # no other car in reach
GOAL_HEAVY = np.array([-1e-3, -1e-2, -1e-3, -1e-3, -1.0])  # merge right as fast as possible


def _penalised_best(oxy, goal, w):
    """The soft penalty's best answer over the planner's seeds (B = 10 solves)."""
    seeds = strategy_seeds()
    n = len(seeds)
    z = seeds.astype(np.float64).copy()
    F, its = np.empty(n), np.empty(n, np.int64)
    kernels.solve_batch(z, np.repeat(oxy[None, :, 0], n, 0), np.repeat(oxy[None, :, 1], n, 0),
                        np.full(n, goal, np.int64), np.repeat(w[None], n, 0), 200, 1e-7, F, its)
    return z[np.argmin(F)].copy()


def _fd_check(z, ox, oy, goal, w, lam, rho):
    g, H = np.empty(2 * K), np.empty((2 * K, 2 * K))
    kernels.al_objective_grad_hess(z, ox, oy, goal, w, lam, rho, g, H, True)
    fd_g, fd_H = np.empty_like(g), np.empty_like(H)
    g2, H2 = np.empty_like(g), np.empty_like(H)
    for j in range(2 * K):
        e = np.zeros(2 * K)
        e[j] = 1e-6
        zp, zm = (z.reshape(-1) + e).reshape(K, 2), (z.reshape(-1) - e).reshape(K, 2)
        fd_g[j] = (kernels.al_objective(zp, ox, oy, goal, w, lam, rho)
                   - kernels.al_objective(zm, ox, oy, goal, w, lam, rho)) / 2e-6
        kernels.al_objective_grad_hess(zp, ox, oy, goal, w, lam, rho, g2, H2, False)
        gp = g2.copy()
        kernels.al_objective_grad_hess(zm, ox, oy, goal, w, lam, rho, g2, H2, False)
        fd_H[:, j] = (gp - g2) / 2e-6
    assert np.allclose(g, fd_g, rtol=1e-5, atol=1e-6 * np.abs(g).max())
    assert np.allclose(H, fd_H, rtol=1e-4, atol=1e-5 * np.abs(H).max())


def test_augmented_lagrangian_and_lagrangian_terms_have_exact_derivatives():
    w = objective_weights(GOAL_HEAVY, default_normalisers())[0]
    z = _penalised_best(FAR, 0, w)
    c = np.empty(NC)
    constrained.limit_values(z, 0, c)
    assert c.max() > -0.5  # near the road edge: the limits' terms are live here
    lam = np.where(c > -1.0, 0.3, 0.0)
    ox, oy = np.ascontiguousarray(FAR[:, 0]), np.ascontiguousarray(FAR[:, 1])
    for rho in (-1.0, 10.0):  # the Lagrangian (lam . c) and the AL with some limits past lam + rho c = 0
        _fd_check(z, ox, oy, 0, w, lam, rho)


@pytest.mark.parametrize("theta, pressed", [(GOAL_HEAVY, True), (np.array([-1.0, -0.1, -1.0, -0.1, -0.5]), False)])
def test_reaches_the_hard_references_optimum_where_the_penalty_falls_short(theta, pressed):
    """No other car in reach, merge right: with the goal weighted heavily the car rushes right and
    presses against |x| = 12, where the penalty's answer stops short by 3e-4; with theta*'s shape no
    limit is active and all three agree.  (Where the solve cannot certify a KKT point it keeps the
    penalty's answer and says so, status 2: then it claims nothing, and the planner counts it.)"""
    norm = default_normalisers()
    w = objective_weights(theta, norm)[0]
    nt = np.linalg.norm(theta)

    def normalised_reward(z):
        return reward(raw_features(z[None], FAR[None], np.array([0])) / norm, theta)[0] / nt

    z = _penalised_best(FAR, 0, w)
    zc = z.copy()
    ox, oy = np.ascontiguousarray(FAR[:, 0]), np.ascontiguousarray(FAR[:, 1])
    _, _, resid, status = constrained.constrained_one(zc, ox, oy, 0, w, 200, 1e-7, 1e-9)
    assert status in ((1,) if pressed else (0, 1)) and resid <= 1e-9
    ref = reference_hard.solve_hard(FAR, 0, theta, norm, starts=reference_hard.hard_starts()[:8])
    r_ref = reward(ref["phi"] / norm, theta) / nt
    assert abs(r_ref - normalised_reward(zc)) <= 1e-10
    if pressed:
        assert r_ref - normalised_reward(z) > 1e-4  # the penalty's offset: the reason for this module
        m = reference_hard.margins(zc, 0)  # the reference's own margins: on |x| = 12, nowhere past it
        assert -1e-9 <= m["road_min"] <= 1e-6 and m["violation_ft"] <= 1e-9


@pytest.fixture(scope="module")
def two_plans():
    envs = np.array([environment_id(0, 100, 2, 50), environment_id(1, -140, 1, 70, 1.0, 80),
                     environment_id(0, -200, 0, 20), environment_id(1, 120, 1, 30)])
    thetas, norm = sample_thetas(24), default_normalisers()
    return envs, thetas, plan_chunk(envs, thetas, norm), plan_chunk(envs, thetas, norm, PlannerSettings(exact=True))


def test_an_exact_plan_is_never_worse_and_stays_within_the_limits(two_plans):
    env_ids, thetas, soft, hard = two_plans
    gain = (reward(hard["features"], thetas) - reward(soft["features"], thetas)) / np.linalg.norm(thetas, axis=1)
    assert gain.min() >= -1e-12
    assert (gain > 1e-6).any()  # somewhere the penalty's offset was worth more than exact IRL's tolerance
    goal = np.repeat(get_environments(env_ids).goal, len(thetas))
    excess = limit_excess(hard["controls"].astype(np.float64).reshape(-1, K, 2), goal)
    assert excess.max() <= STORED_FEAS_TOL
    assert excess.max() > -1e-3  # and it does go up to the limits, unlike the penalty (0.14 ft short at least)
    assert limit_excess(soft["controls"].astype(np.float64).reshape(-1, K, 2), goal).max() < -0.05
