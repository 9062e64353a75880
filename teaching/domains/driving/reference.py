"""An independent reference solver for one (environment, theta) problem: a
global multi-start search that shares nothing with the planner's search (not
its strategy seeds, anchors, warm starts or Newton kernel), only the exact
objective F(z) of :mod:`teaching.domains.driving.kernels` (penalties included) and its exact
derivatives.  Slow by design; used by bench/planner.py and the tests.

**Starts** (:func:`reference_starts`, 53 by default, generated here):

* 7 straight drives: constant acceleration -1, -1/2, 0, 1/2, 1 (fractions of
  the bound), and brake-then-throttle / throttle-then-brake (sign flips half-way);
* 24 lane changes: right / left x starting at knot 0, 2, 4, 6 x constant
  acceleration -0.6, 0, 0.6; a 4-knot steer-rate pulse (+a, -a, -a, +a) whose
  amplitude a is found by bisection on this module's own Euler rollout so that
  the car ends exactly one lane over at that acceleration (every lane is some
  start's end lane: the lane-end constraint keeps a local search in its lane);
* 6 slow lane changes: right / left x starting at knot 0, 2, 4, a 6-knot pulse
  (+a, 0, -a, -a, 0, +a), same calibration, constant speed;
* 16 points of a scrambled Sobol sequence (seed 0) in [-1, 1]^(K x 2), the
  steer-rate column scaled by 0.3 (full-range random steering spins the car).

**Search**: every start is run with SciPy L-BFGS-B on the box [-1, 1]^(2K) with
the exact gradient (``objective_grad_hess(..., want_hess=False)``).

**Polish**: the `n_polish` (16) best distinct local solutions (by F) are
polished by :func:`polish`, a projected Newton method written here in NumPy:
the exact Hessian (``want_hess=True``) on the free variables (epsilon-active set
of Bertsekas), made positive definite by taking |eigenvalues| (floored) plus a
Levenberg shift that grows while steps are cut short, Armijo backtracking along
the projection arc, until the projected gradient z - clip(z - grad F) is below
`tol` (1e-10) in every component; a step whose predicted decrease is below what
F resolves (~1e-18) is judged by the projected gradient instead.  300 iterations
each, then the `n_extend` (4) best still unfinished get up to 5,000 more: where
the car presses against a stiff constraint penalty (x at the outer lane centre,
the lane-end band), Newton slides along the curved penalty valley in short steps
for hundreds of iterations, and L-BFGS-B stops far from it.  The answer is the
polished solution with the smallest F (penalties included, so no constraint is
traded for reward).

**Gap** (:func:`reference_gap`): the answer's reward under theta, from
``raw_features(...) / normalisers`` and ``features.reward`` exactly as a table's
features are computed, minus the table's, over |theta|.  The answer is not
rounded to the table's float32: where a constraint penalty is active at the
optimum, float32 rounding alone moves a trajectory's reward by up to ~1e-8, so
|gaps| of that size are the storage floor, not a different optimum.
Measured on this 2-core machine: ~1.2 s of one core per problem (0.6-2.7 s),
nearly all of it in the 53 L-BFGS-B runs: 0.6 s (idle) to 1.4 s (loaded) per pair with 2 workers.
"""
from __future__ import annotations

import math
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy.optimize import minimize
from scipy.stats import qmc
from threadpoolctl import threadpool_limits

from . import kernels
from .environments import get_environments, other_car_states
from .features import raw_features, reward
from .planner import objective_weights
from .world import WORLD

K = WORLD.n_knots
NV = 2 * K


def _lateral_shift(steer, accel):
    """x_T of this module's own explicit Euler rollout of knot controls (fractions of the bounds)."""
    W = WORLD
    x, h, v, st = 0.0, math.pi / 2, W.v_init, 0.0
    for t in range(W.horizon):
        k = t // W.steps_per_knot
        x, h = x + W.dt * v * math.cos(h), h + W.dt / W.wheelbase * v * math.tan(st)
        v += W.dt * W.accel_max * accel
        st = min(max(st + W.dt * W.steer_rate_max * steer[k], -W.steer_max), W.steer_max)
    return x


def _lane_change(pulse, start, accel, direction):
    """Knots (K, 2): steer pulse at `start`, amplitude bisected to end `direction` (+1 right) one lane over."""
    shape = np.zeros(K)
    shape[start:start + len(pulse)] = pulse
    lo, hi = 0.0, 1.0
    for _ in range(50):  # -steer turns towards +x; the shift grows with the amplitude
        a = 0.5 * (lo + hi)
        lo, hi = (a, hi) if _lateral_shift(-a * shape, accel) < WORLD.lane_width else (lo, a)
    return np.stack([-direction * a * shape, np.full(K, accel)], axis=-1)


def reference_starts(n_random: int = 16, seed: int = 0) -> np.ndarray:
    """The reference's starts (S, K, 2) in [-1, 1] (module docstring)."""
    straight = [np.full(K, a) for a in (-1.0, -0.5, 0.0, 0.5, 1.0)]
    half = np.where(np.arange(K) < K // 2, -1.0, 1.0)
    starts = [np.stack([np.zeros(K), a], -1) for a in straight + [half, -half]]
    for d in (1, -1):
        starts += [_lane_change([1, -1, -1, 1], s, a, d) for s in range(0, K - 3, 2) for a in (-0.6, 0.0, 0.6)]
        starts += [_lane_change([1, 0, -1, -1, 0, 1], s, 0.0, d) for s in range(0, K - 5, 2)]
    sob = 2.0 * qmc.Sobol(NV, scramble=True, seed=seed).random(n_random) - 1.0
    sob = sob.reshape(n_random, K, 2) * [0.3, 1.0]
    return np.clip(np.concatenate([np.array(starts), sob]), -1.0, 1.0)


class Problem:
    """F, grad F and hess F of one problem on flat z (NV,), through the exact kernels."""

    def __init__(self, other_xy, goal, weights):
        self.ox = np.ascontiguousarray(other_xy[:, 0], dtype=np.float64)
        self.oy = np.ascontiguousarray(other_xy[:, 1], dtype=np.float64)
        self.goal, self.w = int(goal), np.ascontiguousarray(weights, dtype=np.float64)
        self.g, self.H = np.empty(NV), np.empty((NV, NV))

    def fg(self, z, hess=False):
        F = kernels.objective_grad_hess(np.ascontiguousarray(z, dtype=np.float64).reshape(K, 2), self.ox, self.oy,
                                        self.goal, self.w, self.g, self.H, hess)
        return (F, self.g.copy(), self.H.copy()) if hess else (F, self.g.copy())

    def f(self, z):
        return kernels.objective(np.ascontiguousarray(z, dtype=np.float64).reshape(K, 2), self.ox, self.oy,
                                 self.goal, self.w)


def projected_gradient(z, g) -> np.ndarray:
    """z - clip(z - g, -1, 1): zero exactly at a KKT point of the box-constrained problem."""
    z = np.asarray(z, dtype=np.float64).reshape(-1)
    return z - np.clip(z - g, -1.0, 1.0)


def lbfgsb(prob: Problem, z0, maxiter=500, ftol=1e-15, gtol=1e-10) -> np.ndarray:
    """One SciPy L-BFGS-B run on the box from z0; returns flat z (NV,)."""
    res = minimize(prob.fg, np.asarray(z0, float).reshape(-1), jac=True, method="L-BFGS-B",
                   bounds=[(-1.0, 1.0)] * NV, options={"maxiter": maxiter, "ftol": ftol, "gtol": gtol})
    return np.clip(res.x, -1.0, 1.0)


def solve_scipy(z0, other_xy, goal, weights) -> np.ndarray:
    """One L-BFGS-B run from z0 (K, 2) (the benchmark's per-problem baseline); returns knots (K, 2)."""
    return lbfgsb(Problem(other_xy, goal, weights), z0).reshape(K, 2)


def polish(prob: Problem, z0, tol: float = 1e-10, maxiter: int = 300):
    """Projected Newton with the exact Hessian (module docstring); returns (z (NV,), F, max |projected gradient|)."""
    z = np.clip(np.asarray(z0, float).reshape(-1), -1.0, 1.0)
    F, g, H = prob.fg(z, hess=True)
    pg = np.abs(projected_gradient(z, g)).max()
    mu = 0.0  # Levenberg shift: grows while steps are cut short, decays while full steps are taken
    for _ in range(maxiter):
        if pg < tol:
            break
        eps = min(1e-3, pg)  # epsilon-active set: next to a bound with the gradient pointing out
        fixed = ((z <= -1.0 + eps) & (g > 0)) | ((z >= 1.0 - eps) & (g < 0))
        free = ~fixed
        p = np.where(fixed, -g / np.maximum(np.abs(np.diag(H)), 1e-12), 0.0)
        top = 1.0
        if free.any():
            lam, V = np.linalg.eigh(H[np.ix_(free, free)])
            lam = np.abs(lam)
            top = lam.max()
            p[free] = -V @ ((V.T @ g[free]) / np.maximum(lam + mu, 1e-14 * top + 1e-300))
        zn = np.clip(z + p, -1.0, 1.0)
        pred = -(g @ (zn - z) + 0.5 * (zn - z) @ H @ (zn - z))
        if 0.0 <= pred < 1e-15 * max(abs(F), 1e-3):
            # the step's decrease is below what F resolves: take it if it shrinks the projected gradient
            Fn, gn, Hn = prob.fg(zn, hess=True)
            pgn = np.abs(projected_gradient(zn, gn)).max()
            if pgn < pg:
                z, F, g, H, pg = zn, Fn, gn, Hn, pgn
            elif mu > 0.0:
                mu = 0.0
            else:
                break
            continue
        alpha = 1.0
        for _ls in range(80):  # Armijo backtracking along the projection arc
            zn = np.clip(z + alpha * p, -1.0, 1.0)
            Fn = prob.f(zn)
            if Fn < F and Fn <= F + 1e-4 * g @ (zn - z):
                break
            alpha *= 0.5
        else:
            break
        if alpha == 1.0:
            mu = mu / 4.0 if mu > 4e-12 * top else 0.0
        elif alpha < 0.1:
            mu = max(4.0 * mu, 1e-9 * top)
        z = zn
        F, g, H = prob.fg(z, hess=True)
        pg = np.abs(projected_gradient(z, g)).max()
    return z, F, float(pg)


def solve_reference(other_xy, goal, weights, n_polish: int = 16, n_extend: int = 4, starts=None,
                    tol: float = 1e-10) -> dict:
    """Global search for one problem.  Returns a dict: z (K, 2) the answer, F its objective, pg its max
    |projected gradient|, starts (S, K, 2), local (S, K, 2) the L-BFGS-B solutions and local_F (S,)."""
    prob = Problem(other_xy, goal, weights)
    starts = reference_starts() if starts is None else np.asarray(starts, float)
    with single_thread_blas():
        local = np.array([lbfgsb(prob, s) for s in starts])
        local_F = np.array([prob.f(z) for z in local])
        picked = []  # the n_polish best distinct local solutions
        for i in np.argsort(local_F, kind="stable"):
            if len(picked) < n_polish and all(np.abs(local[i] - local[j]).max() > 1e-6 for j in picked):
                picked.append(i)
        done = [polish(prob, local[i], tol) for i in picked]
        for k in sorted(range(len(done)), key=lambda k: done[k][1])[:n_extend]:
            if done[k][2] >= tol:  # the most promising unfinished polishes get the time they need
                done[k] = polish(prob, done[k][0], tol, maxiter=5000)
        best = min(done, key=lambda r: r[1])
    return {"z": best[0].reshape(K, 2), "F": best[1], "pg": best[2], "starts": starts,
            "local": local.reshape(-1, K, 2), "local_F": local_F}


def single_thread_blas():
    """One BLAS thread: SciPy's L-BFGS-B calls BLAS on tiny arrays, and idle threads spinning
    against other work cost 10-100x on a loaded 2-core machine."""
    return threadpool_limits(1)


def _solve_one(args):
    oxy, goal, w, n_polish = args
    r = solve_reference(oxy, goal, w, n_polish)
    return r["z"], r["F"], r["pg"]


def reference_solutions(oxy, goals, weights, n_jobs: int = 2, n_polish: int = 16):
    """solve_reference over problems (other_xy (P, T+1, 2), goals (P,), weights (P, 5)), in n_jobs
    processes.  Returns z (P, K, 2), F (P,), pg (P,)."""
    tasks = [(oxy[i], int(goals[i]), weights[i], n_polish) for i in range(len(goals))]
    if n_jobs > 1 and len(tasks) > 1:
        # spawned, not forked: a fork copies the caller's threads and sockets half-way (a Celery
        # connection pool's after-fork hook hung the child reading a Redis socket it inherited)
        with ProcessPoolExecutor(min(n_jobs, len(tasks)), mp_context=multiprocessing.get_context("spawn")) as pool:
            out = list(pool.map(_solve_one, tasks))
    else:
        out = [_solve_one(t) for t in tasks]
    return (np.array([o[0] for o in out]).reshape(-1, K, 2), np.array([o[1] for o in out]),
            np.array([o[2] for o in out]))


def reference_gap(table, pairs, n_jobs: int = 2, n_polish: int = 16, return_solutions: bool = False):
    """For (env_index, theta_index) pairs of a table: the reference's reward minus the table's under
    theta, over |theta| (normalised reward units; positive = table worse, negative = table better).
    With return_solutions, (gap, {"z": knots (P, K, 2), "F": (P,), "pg": (P,)}) of the reference."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    m, n = pairs[:, 0], pairs[:, 1]
    envs = get_environments(np.asarray(table.env_ids)[m])
    oxy = other_car_states(envs)
    thetas = np.asarray(table.thetas)[n]
    z, F, pg = reference_solutions(oxy, envs.goal, objective_weights(thetas, table.normalisers), n_jobs, n_polish)
    phi = raw_features(z, oxy, envs.goal) / table.normalisers
    mine = np.asarray(table.features)[m, n]
    gap = (reward(phi, thetas) - reward(mine, thetas)) / np.linalg.norm(thetas, axis=1)
    return (gap, {"z": z, "F": F, "pg": pg}) if return_solutions else gap
