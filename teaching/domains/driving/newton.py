"""The planner's solver and parallel loops over the kernels of :mod:`.kernels`.

:func:`newton_one` is projected Newton on the penalised objective for one trajectory;
:func:`solve_batch`, :func:`rollout_batch` and :func:`features_batch` run a kernel over a batch in
parallel; :func:`pool_best` compares the pool's trajectories under every theta for the cross-theta
hand-overs.  :func:`cholesky` is shared with the SQP (:mod:`.constrained`, :mod:`.qp`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numba.core import config as numba_config

from .kernels import (
    ACTIVE_EPS,
    KERNEL_CACHE_DIR,
    NO_MULTIPLIERS,
    NV,
    STRIPES,
    K,
    _backward,
    _forward,
    features_one,
    objective,
    rollout_one,
    trace_buffer,
    workspace,
)

_user_cache_dir = numba_config.CACHE_DIR
numba_config.CACHE_DIR = KERNEL_CACHE_DIR  # kernels.py says why


@njit(cache=True)
def cholesky(A, L):
    """L (n, n) lower triangular with L L' = A (n, n), for SPD A; False if A is not PD.

    Rows are worked two at a time: each entry is the same sum, in the same order, as row by row
    (L[i, j] = (A[i, j] - sum_k<j L[i, k] L[j, k]) / L[j, j]), but the two rows' sums are
    independent chains of subtractions that the CPU runs side by side (1.4x on a 20 x 20 matrix)."""
    n = A.shape[0]
    for i in range(0, n - 1, 2):
        i2 = i + 1
        for j in range(i):
            s, s2 = A[i, j], A[i2, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
                s2 -= L[i2, k] * L[j, k]
            L[i, j] = s / L[j, j]
            L[i2, j] = s2 / L[j, j]
        s, s2 = A[i, i], A[i2, i]
        for k in range(i):
            s -= L[i, k] * L[i, k]
            s2 -= L[i2, k] * L[i, k]
        if s <= 0.0:
            return False
        L[i, i] = math.sqrt(s)
        L[i2, i] = s2 / L[i, i]
        s = A[i2, i2]
        for k in range(i2):
            s -= L[i2, k] * L[i2, k]
        if s <= 0.0:
            return False
        L[i2, i2] = math.sqrt(s)
    if n % 2:  # the last row of an odd n alone
        i = n - 1
        for j in range(i + 1):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if j < i:
                L[i, j] = s / L[j, j]
            elif s <= 0.0:
                return False
            else:
                L[i, i] = math.sqrt(s)
    return True


@njit(cache=True)
def _cholesky_solve(A, b, x):
    """Solve A x = b for SPD A in place of a copy; False if A is not PD."""
    L = np.zeros(A.shape)
    if not cholesky(A, L):
        return False
    _solve_factored(L, b, x)
    return True


@njit(cache=True)
def _solve_factored(L, b, x):
    """x = (L L')^-1 b, by forward and back substitution with the Cholesky factor L."""
    n = L.shape[0]
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(cache=True)
def newton_one(z, ox, oy, goal, w, maxiter, tol):
    """Projected Newton on the box [-1, 1]^NV from z (modified in place).

    Newton directions on the free variables with a Levenberg shift that makes
    the reduced Hessian positive definite and adapts to how far the last step
    could go, Armijo backtracking along the projection arc.  Returns (F, iterations).
    """
    g = np.empty(NV)
    H = np.empty((NV, NV))
    Hf = np.empty((NV, NV))
    rhs = np.empty(NV)
    p = np.empty(NV)
    L = np.empty((NV, NV))  # Hf's Cholesky factor: cholesky reads only the entries it has written
    free = np.empty(NV, np.bool_)
    held = np.empty(NV, np.bool_)  # held on the bound it is next to: the Newton step would carry it past
    to_bound = np.empty(NV)  # ... by this displacement (bound - z_i)
    zf = z.reshape(NV)
    zn = np.empty(NV)
    # the Hessian only once the gradient says another step is needed: the last point's would go unused
    work = workspace()
    trace = trace_buffer()  # the line search's accepted point's transcendentals, for the next _forward
    F = _forward(z, ox, oy, goal, w, NO_MULTIPLIERS, False, g, work, trace, False)
    damping = 0.0
    it = 0
    for it in range(maxiter):  # noqa: B007  (returned: the iterations taken)
        # epsilon-active set (Bertsekas): a variable within eps of a bound whose
        # gradient points outward is fixed, else a Newton step for it would be
        # clipped at the bound and could go uphill.  eps shrinks with the
        # projected-gradient residual, so near a solution this is the exact active set.
        pg = 0.0
        resid = 0.0
        for i in range(NV):
            zi = min(1.0, max(-1.0, zf[i] - g[i]))
            resid += (zf[i] - zi) ** 2
            if not ((zf[i] <= -1.0 and g[i] > 0.0) or (zf[i] >= 1.0 and g[i] < 0.0)):
                pg = max(pg, abs(g[i]))
        if pg < tol:
            break
        _backward(ox, oy, goal, w, NO_MULTIPLIERS, False, work, H)
        eps_act = min(ACTIVE_EPS, math.sqrt(resid))
        for i in range(NV):
            free[i] = not ((zf[i] <= -1.0 + eps_act and g[i] > 0.0) or (zf[i] >= 1.0 - eps_act and g[i] < 0.0))
        scale = 0.0
        for i in range(NV):
            scale = max(scale, abs(H[i, i]))
        mu = damping
        held[:] = False
        for _rounds in range(NV):
            for _attempt in range(30):
                for i in range(NV):
                    for j in range(NV):
                        Hf[i, j] = H[i, j] if (free[i] and free[j]) else 0.0
                    Hf[i, i] = (H[i, i] if free[i] else 1.0) + mu
                    rhs[i] = -g[i] if free[i] else 0.0
                    if free[i]:
                        for j in range(NV):
                            if held[j]:
                                rhs[i] -= H[i, j] * to_bound[j]
                if cholesky(Hf, L):
                    _solve_factored(L, rhs, p)
                    break
                mu = max(1e-10 * (scale + 1.0), 10.0 * mu)
            # A free variable next to a bound (the gradient points inwards, or it is not quite on
            # it) whose Newton step would carry it past the bound: the projection would clip it
            # there while the others took steps computed as if it went on, so the step is wrong
            # for them, the line search cuts it to as little as 2^-19 (F rose by 1e6 through a limit's
            # penalty) and the next iteration flips back.  Hold it on the bound and solve again
            # for the others given that displacement: the box-constrained model's step.
            # (Holding it where it was, with a scaled gradient step off the bound, crawls: a tenth of
            # warm starts took 20 to 90 iterations; docs/decisions.md, "Held on the bound".)
            changed = False
            for i in range(NV):
                if free[i] and ((zf[i] <= -1.0 + eps_act and zf[i] + p[i] < -1.0)
                                or (zf[i] >= 1.0 - eps_act and zf[i] + p[i] > 1.0)):
                    free[i] = False
                    held[i] = True
                    to_bound[i] = (-1.0 if p[i] < 0.0 else 1.0) - zf[i]
                    changed = True
            if not changed:
                break
        for i in range(NV):
            if held[i]:
                p[i] = to_bound[i]
            elif not free[i]:  # scaled gradient step: projection puts it on its bound
                p[i] = -g[i] / max(abs(H[i, i]), 1e-12)
        alpha = 1.0
        accepted = False
        Fn = F
        for _ls in range(30):
            dec = 0.0
            for i in range(NV):
                zn[i] = min(1.0, max(-1.0, zf[i] + alpha * p[i]))
                dec += g[i] * (zn[i] - zf[i])
            Fn = objective(zn.reshape(K, 2), ox, oy, goal, w, trace)
            if Fn <= F + 1e-4 * dec:
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            break
        # Levenberg-Marquardt gain ratio: actual over predicted decrease of the step
        # taken.  Where the quadratic model predicted it poorly, damp the next step;
        # where it predicted well, decay back towards pure Newton.  The ratio alone
        # decides: a step shortened by the line search but well predicted says the
        # model holds, and damping it as well left 1.5 % of warm starts crawling to
        # the iteration cap (docs/decisions.md, "Projected Newton at the bounds").
        pred = 0.0
        for i in range(NV):
            si = zn[i] - zf[i]
            hs = 0.0
            for j in range(NV):
                hs += H[i, j] * (zn[j] - zf[j])
            pred -= si * (g[i] + 0.5 * hs)
        rho = (F - Fn) / pred if pred > 0.0 else 0.0
        if rho > 0.75:
            damping = mu / 3.0 if mu / 3.0 > 1e-12 * (scale + 1.0) else 0.0
        elif rho < 0.25:
            damping = max(2.0 * mu, 1e-9 * (scale + 1.0))
        else:
            damping = mu
        zf[:] = zn
        # No stop on a small decrease: near a constraint the last digits come in many small
        # steps, and stopping on |dF| < 1e-13 left the projected gradient at 1e-5 and F up to
        # 3e-7 short of the optimum.  Only the tolerance, a failed line search or maxiter stop it.
        F = _forward(z, ox, oy, goal, w, NO_MULTIPLIERS, False, g, work, trace, True)  # z: the last point evaluated
    return F, it


@njit(parallel=True, cache=True)
def solve_batch(z, ox, oy, goal, w, maxiter, tol, F_out, it_out):
    """Run newton_one on every problem (in parallel). z (B, K, 2) updated in place.

    Threads take interleaved stripes (problems s, s + STRIPES, ...), not contiguous blocks: a
    batch is ordered by environment, and the hard ones (merging) sit together, so contiguous
    blocks left one thread working while the other idled (1.4x on 2 cores instead of ~2x)."""
    n = z.shape[0]
    for s in prange(STRIPES):
        for b in range(s, n, STRIPES):
            F, it = newton_one(z[b], ox[b], oy[b], goal[b], w[b], maxiter, tol)
            F_out[b] = F
            it_out[b] = it


@njit(parallel=True, cache=True)
def rollout_batch(z, out):
    for b in prange(z.shape[0]):
        rollout_one(z[b], out[b])


@njit(parallel=True, cache=True)
def features_batch(z, ox, oy, goal, out):
    for b in prange(z.shape[0]):
        features_one(z[b], ox[b], oy[b], goal[b], out[b])




@njit(cache=True, inline="always")
def _reward5(phi, p, t0, t1, t2, t3, t4):
    """theta . phi[p] summed left to right like features.reward, so the two agree to the bit."""
    return (((phi[p, 0] * t0 + phi[p, 1] * t1) + phi[p, 2] * t2) + phi[p, 3] * t3) + phi[p, 4] * t4


POOL_BLOCK = 16  # thetas compared with each pool trajectory side by side (4: 1.6x, 16: 5.4x one at a time)


@njit(cache=True, parallel=True)
def pool_best(pool_phi, thetas, allowed, own, best, best_r, own_r):
    """For every theta (N, 5): best (N,) the first index of the largest theta . phi over the allowed
    pool trajectories (P, 5; allowed (P,) bool), best_r (N,) that reward (-inf and index 0 if none is
    allowed), own_r (N,) the reward of pool trajectory own[i] (-inf if it is not allowed).  One pass,
    without an (N, P) reward matrix (which, written and then scanned by argmax, took ~8 % of a
    chunk's time in a profile), over blocks of POOL_BLOCK thetas: each pool trajectory is read once
    per block and its rewards under the block's thetas run side by side in vector registers, each
    summed as _reward5 sums it and kept only if strictly larger (the first index wins a tie), so the
    answer is the same to the bit as one theta at a time."""
    n = thetas.shape[0]
    for blk in prange((n + POOL_BLOCK - 1) // POOL_BLOCK):
        i0 = blk * POOL_BLOCK
        th = np.zeros((5, POOL_BLOCK))  # the block's thetas, a row per feature (padding: zeros, ignored)
        for j in range(min(POOL_BLOCK, n - i0)):
            for f in range(5):
                th[f, j] = thetas[i0 + j, f]
        rb = np.full(POOL_BLOCK, -np.inf)
        bb = np.zeros(POOL_BLOCK, np.int64)
        for p in range(pool_phi.shape[0]):
            if allowed[p]:
                f0, f1, f2, f3, f4 = pool_phi[p, 0], pool_phi[p, 1], pool_phi[p, 2], pool_phi[p, 3], pool_phi[p, 4]
                for j in range(POOL_BLOCK):
                    r = (((f0 * th[0, j] + f1 * th[1, j]) + f2 * th[2, j]) + f3 * th[3, j]) + f4 * th[4, j]
                    better = r > rb[j]  # as selects, not branches, so the loop vectorises
                    rb[j] = r if better else rb[j]
                    bb[j] = p if better else bb[j]
        for j in range(min(POOL_BLOCK, n - i0)):
            i = i0 + j
            best[i] = bb[j]
            best_r[i] = rb[j]
            o = own[i]
            own_r[i] = _reward5(pool_phi, o, thetas[i, 0], thetas[i, 1], thetas[i, 2], thetas[i, 3],
                                thetas[i, 4]) if allowed[o] else -np.inf


numba_config.CACHE_DIR = _user_cache_dir
