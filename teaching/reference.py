"""The per-problem reference solver: scipy.optimize.minimize (L-BFGS-B) with the
project's exact gradient, on the same parameterisation and objective as the
planner.  Slow by design; used by bench/planner.py and the quality tests.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from . import kernels
from .environments import get_environments, other_car_states
from .features import raw_features, reward
from .planner import objective_weights, strategy_seeds
from .world import WORLD

NV = 2 * WORLD.n_knots


def solve_scipy(z0, other_xy, goal, weights) -> np.ndarray:
    """One L-BFGS-B run from z0 (K, 2); returns the optimised knots (K, 2)."""
    ox, oy = np.ascontiguousarray(other_xy[:, 0]), np.ascontiguousarray(other_xy[:, 1])
    g = np.empty(NV)
    H = np.empty((NV, NV))

    def fun(zflat):
        F = kernels.objective_grad_hess(zflat.reshape(-1, 2), ox, oy, int(goal), weights, g, H, False)
        return F, g.copy()

    res = minimize(fun, np.asarray(z0, float).reshape(-1), jac=True, method="L-BFGS-B",
                   bounds=[(-1.0, 1.0)] * NV, options={"maxiter": 500, "ftol": 1e-15, "gtol": 1e-10})
    return res.x.reshape(-1, 2)


def reference_gap(table, pairs, n_starts: int = 8):
    """For (env_index, theta_index) pairs of a table: how much worse the table's
    trajectory is than the best of an n_starts SciPy reference, in normalised
    reward units (theta . phi / |theta|, exact features).  Negative = table better.
    """
    seeds = strategy_seeds()[:n_starts]
    gaps = []
    for m, n in pairs:
        env = get_environments(table.env_ids[[m]])
        oxy = other_car_states(env)[0]
        theta = table.thetas[n]
        w = objective_weights(theta, table.normalisers)[0]
        sols = np.array([solve_scipy(s, oxy, env.goal[0], w) for s in seeds])
        phi = raw_features(sols, np.repeat(oxy[None], len(sols), 0), np.repeat(env.goal, len(sols))) / table.normalisers
        best = reward(phi, theta).max()
        mine = reward(np.asarray(table.features[m, n]), theta)
        gaps.append((best - mine) / np.linalg.norm(theta))
    return np.array(gaps)
