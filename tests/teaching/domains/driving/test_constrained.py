"""The planner's hard-limit solve (teaching/domains/driving/constrained.py): the Lagrangian and the limits
have exact derivatives; the QP solver agrees with brute force over active sets; from the soft
penalty's answer it reaches the optimum that the independent hard-constraint reference
(teaching/domains/driving/reference_hard.py: its own rollout, starts and SLSQP) finds, where the penalty's answer
falls short; and a chunk planned (exact by default) is never worse than a penalised one, feasible to
the stored precision."""
import itertools

import numpy as np
import pytest

from teaching.core.candidates import sample_thetas
from teaching.domains.driving import constrained, kernels, newton, qp, reference_hard
from teaching.domains.driving.environments import environment_id, get_environments, other_car_states
from teaching.domains.driving.features import default_normalisers, raw_features, reward
from teaching.domains.driving.planner import (
    STORED_FEAS_TOL,
    PlannerSettings,
    limit_excess,
    objective_weights,
    plan_chunk,
    strategy_seeds,
)
from teaching.domains.driving.world import THETA_STAR, WORLD

K, T, NC = WORLD.n_knots, WORLD.horizon, kernels.NC
FAR = np.stack([np.zeros(T + 1), np.full(T + 1, 1e6)], axis=1)  # no other car in reach
GOAL_HEAVY = np.array([-1e-3, -1e-2, -1e-3, -1e-3, -1.0])  # merge right as fast as possible


def _penalised_best(oxy, goal, w):
    """The soft penalty's best answer over the planner's seeds (B = 10 solves)."""
    seeds = strategy_seeds()
    n = len(seeds)
    z = seeds.astype(np.float64).copy()
    F, its = np.empty(n), np.empty(n, np.int64)
    newton.solve_batch(z, np.repeat(oxy[None, :, 0], n, 0), np.repeat(oxy[None, :, 1], n, 0),
                        np.full(n, goal, np.int64), np.repeat(w[None], n, 0), 200, 1e-7, F, its)
    return z[np.argmin(F)].copy()


def _fd_check(z, ox, oy, goal, w, lam):
    g, H = np.empty(2 * K), np.empty((2 * K, 2 * K))
    kernels.lagrangian_grad_hess(z, ox, oy, goal, w, lam, g, H, True)
    fd_g, fd_H = np.empty_like(g), np.empty_like(H)
    g2, H2 = np.empty_like(g), np.empty_like(H)
    for j in range(2 * K):
        e = np.zeros(2 * K)
        e[j] = 1e-6
        zp, zm = (z.reshape(-1) + e).reshape(K, 2), (z.reshape(-1) - e).reshape(K, 2)
        fd_g[j] = (kernels.lagrangian(zp, ox, oy, goal, w, lam) - kernels.lagrangian(zm, ox, oy, goal, w, lam)) / 2e-6
        kernels.lagrangian_grad_hess(zp, ox, oy, goal, w, lam, g2, H2, False)
        gp = g2.copy()
        kernels.lagrangian_grad_hess(zm, ox, oy, goal, w, lam, g2, H2, False)
        fd_H[:, j] = (gp - g2) / 2e-6
    assert np.allclose(g, fd_g, rtol=1e-5, atol=1e-6 * np.abs(g).max())
    assert np.allclose(H, fd_H, rtol=1e-4, atol=1e-5 * np.abs(H).max())


def _away_from_kinks(z, goal):
    """(NC,) bool: limits whose |.| is differentiable at z with room for finite differences (|x_t|
    away from x_t = 0, |x_T - lane| away from the lane centre, |h_T - pi/2| away from straight)."""
    s = np.empty((T + 1, 5))
    kernels.rollout_one(z, s)
    x, h = s[1:, 0], s[T, 2]
    lane = 12.0 if goal == 0 else np.clip(12.0 * np.floor(x[-1] / 12.0 + 0.5), -12.0, 12.0)
    return np.concatenate([np.abs(x) > 1e-3, [abs(x[-1] - lane) > 1e-3, abs(h - np.pi / 2) > 1e-3]])


@pytest.mark.parametrize("goal, theta", [(0, GOAL_HEAVY), (1, np.array([-1.0, -0.1, -1.0, -1.0, -0.2]))])
def test_the_lagrangian_and_the_limits_have_exact_derivatives(goal, theta):
    w = objective_weights(theta, default_normalisers())[0]
    z = _penalised_best(FAR, goal, w)
    z[:, 0] += 0.05 * np.sin(np.arange(K))  # off the straight drive: no limit at its kink
    smooth = _away_from_kinks(z, goal)
    c, A = np.empty(NC), np.empty((NC, 2 * K))
    constrained.limit_jacobian(z, goal, c, A)
    c2 = np.empty(NC)
    constrained.limit_values(z, goal, c2)
    assert np.array_equal(c, c2)
    lam = np.where(smooth, 0.3, 0.0)  # every limit's curvature enters the Lagrangian
    assert smooth[4:].all()  # (x_1 .. x_4 stay within 1e-3 ft of 0 for a car that starts straight)
    ox, oy = np.ascontiguousarray(FAR[:, 0]), np.ascontiguousarray(FAR[:, 1])
    _fd_check(z, ox, oy, goal, w, lam)
    fd_A = np.empty_like(A)
    for j in range(2 * K):
        e = np.zeros(2 * K)
        e[j] = 1e-6
        cp, cm = np.empty(NC), np.empty(NC)
        constrained.limit_values((z.reshape(-1) + e).reshape(K, 2), goal, cp)
        constrained.limit_values((z.reshape(-1) - e).reshape(K, 2), goal, cm)
        fd_A[:, j] = (cp - cm) / 2e-6
    assert np.allclose(A[smooth], fd_A[smooth], rtol=1e-5, atol=1e-6 * np.abs(A).max())


def test_qp_solver_agrees_with_brute_force_over_active_sets():
    """min 1/2 x'Gx + a'x s.t. N x >= b: the optimum is the best feasible point among the
    equality-constrained minimisers of every subset of constraints (KKT with lam >= 0)."""
    rng = np.random.default_rng(3)
    for trial in range(40):
        n, m = 4, 6
        R = rng.normal(size=(n, n))
        G = R @ R.T + 0.1 * np.eye(n)
        a, N, b = rng.normal(size=n), rng.normal(size=(m, n)), rng.normal(size=m) - 0.5
        if trial % 4 == 0:
            N[5] = 2.0 * N[4]  # a redundant pair: parallel normals
            b[5] = 2.0 * b[4]
        x, u, act = np.empty(n), np.empty(m), np.zeros(m, bool)
        assert qp.qp_solve(np.linalg.inv(G), a, N, b, m, x, u, act)
        best = None
        for k in range(m + 1):
            for S in itertools.combinations(range(m), k):
                S = list(S)
                KKT = np.block([[G, -N[S].T], [N[S], np.zeros((k, k))]])
                try:
                    sol = np.linalg.solve(KKT, np.concatenate([-a, b[S]]))
                except np.linalg.LinAlgError:
                    continue
                xs = sol[:n]
                if np.all(N @ xs >= b - 1e-9) and np.all(sol[n:] >= -1e-9):
                    f = 0.5 * xs @ G @ xs + a @ xs
                    if best is None or f < best[0]:
                        best = (f, xs)
        assert best is not None
        assert np.allclose(x, best[1], atol=1e-8)
        assert np.all(u >= 0) and np.all(N @ x >= b - 1e-9)
        assert np.allclose(G @ x + a, N.T @ u, atol=1e-8)  # stationarity with the solver's multipliers


@pytest.mark.parametrize("theta, pressed", [(GOAL_HEAVY, True), (np.array([-1.0, -0.1, -1.0, -0.1, -0.5]), False)])
def test_reaches_the_hard_references_optimum_where_the_penalty_falls_short(theta, pressed):
    """No other car in reach, merge right: with the goal weighted heavily the car rushes right and
    presses against |x| = 12, where the penalty's answer stops short by 3e-4; with theta*'s shape no
    limit is active and all three agree.  (Where the solve cannot reach a KKT point it keeps the
    penalty's answer and says so, status 2: then it claims nothing, and the planner counts it.)"""
    norm = default_normalisers()
    w = objective_weights(theta, norm)[0]
    nt = np.linalg.norm(theta)

    def normalised_reward(z):
        return reward(raw_features(z[None], FAR[None], np.array([0])) / norm, theta)[0] / nt

    z = _penalised_best(FAR, 0, w)
    zc = z.copy()
    ox, oy = np.ascontiguousarray(FAR[:, 0]), np.ascontiguousarray(FAR[:, 1])
    _, _, status = constrained.constrained_one(zc, ox, oy, 0, w, 200, 1e-7, 1e-9, False)
    assert status in ((1,) if pressed else (0, 1))
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
    thetas, norm = sample_thetas(24, theta_star=THETA_STAR), default_normalisers()
    return (envs, thetas, plan_chunk(envs, thetas, norm, PlannerSettings(exact=False)),
            plan_chunk(envs, thetas, norm))  # exact by default


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


def test_a_forward_pass_from_the_line_searchs_trace_is_the_same_to_the_bit():
    """Newton's and the SQP's forward pass read the transcendentals that the line search has just
    computed at the same point (kernels.trace_buffer) instead of computing them again.  Value, gradient
    and everything kept for the Hessian must be the very bits of a pass that computes them itself,
    under the soft penalty and under hard limits, on trajectories pressed against the road's limit
    (the penalty's softplus terms) and away from it, beside another car (the closeness kernel)."""
    envs = get_environments([5662, 15474, 16950, 18182])  # tailgating (5662, 15474), merging, a zigzag optimum
    oxy_all = other_car_states(envs)
    rng = np.random.default_rng(22)
    for oxy, goal in zip(oxy_all, envs.goal, strict=True):
        ox, oy = np.ascontiguousarray(oxy[:, 0]), np.ascontiguousarray(oxy[:, 1])
        w = objective_weights(THETA_STAR, default_normalisers())[0]
        pressed = _penalised_best(oxy, goal, objective_weights(GOAL_HEAVY, default_normalisers())[0])
        for z in (pressed, rng.uniform(-1, 1, (K, 2)), strategy_seeds()[3]):
            z = np.ascontiguousarray(z, dtype=np.float64)
            lam = rng.uniform(0.0, 1e-3, NC)
            trace = kernels.trace_buffer()
            assert kernels.objective(z, ox, oy, goal, w, trace) == kernels.objective(z, ox, oy, goal, w)
            hard_trace = kernels.trace_buffer()
            c, c_plain = np.empty(NC), np.empty(NC)
            assert (constrained.true_objective_and_limits(z, ox, oy, goal, w, c, hard_trace)
                    == constrained.true_objective(z, ox, oy, goal, w))
            constrained.limit_values(z, goal, c_plain)
            assert np.array_equal(c, c_plain)
            for hard, mult, tr in ((False, kernels.NO_MULTIPLIERS, trace), (True, lam, hard_trace)):
                passes = []
                for traced in (False, True):
                    g, H, work = np.empty(2 * K), np.empty((2 * K, 2 * K)), kernels.workspace()
                    for kept in work:  # (np.empty where a pass never writes: compare what it writes)
                        kept[...] = 0
                    given = tr if traced else np.full_like(tr, np.nan)  # (untraced: must not be read)
                    F = kernels._forward(z, ox, oy, goal, w, mult, hard, g, work, given, traced)
                    kernels._backward(ox, oy, goal, w, mult, hard, work, H)
                    passes.append((F, g, H, work))
                (F1, g1, H1, work1), (F2, g2, H2, work2) = passes
                assert F1 == F2
                assert np.array_equal(g1, g2) and np.array_equal(H1, H2)
                assert all(np.array_equal(a, b) for a, b in zip(work1, work2, strict=True))
