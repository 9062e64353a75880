"""The optimum with the world's limits as hard constraints, one trajectory at a time (docs/decisions.md).

The soft penalty of :mod:`teaching.domains.driving.kernels` finds the basins fast, but its minimiser lies a little
inside each limit it presses against (0.16-0.36 ft from |x| = 12 in a demo table planned with the penalty alone, up to
1.4e-3 normalised reward units short of the constrained optimum).  From that point (feasible, and
near the optimum) :func:`constrained_one` runs sequential quadratic programming (:func:`sqp_one`):
Newton steps on the KKT conditions, each the solution of a small dense QP with every linearised
limit and the controls' box (Goldfarb-Idnani's dual active-set method, :func:`qp_solve`), so the
active limits are found by the QP itself and redundant ones (a car running along x = 12 meets
several at once) need no care.  Under hard limits the merge feature sum_t max(0, 12 - x_t)^2 is
taken as its smooth extension sum_t (12 - x_t)^2 (kernels.lagrangian_grad_hess): equal wherever the road's
limit |x_t| <= 12 holds, without the kink that lies exactly on it.

Limits (NC = T + 2 values c <= 0, in ft; :func:`limit_values`): |x_t| <= x_limit at t = 1..T; the
lane-end band |x_T - lane| <= lane_end_band; H_SCALE (|h_T - pi/2| - heading_end_band) for the end
heading.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numba.core import config as numba_config

from .kernels import (
    BAND,
    H0,
    H_BAND,
    H_SCALE,
    KERNEL_CACHE_DIR,
    LW,
    NC,
    NV,
    STRIPES,
    X_LIM,
    T,
    _backward,
    _forward,
    features_of_states,
    features_one,
    overshoot_penalty,
    rollout_one,
    trace_buffer,
    workspace,
)
from .newton import _cholesky_solve, newton_one
from .qp import _inverse_spd, _normal_gram, qp_solve

_user_cache_dir = numba_config.CACHE_DIR
numba_config.CACHE_DIR = KERNEL_CACHE_DIR  # kernels.py says why

LAM_NEGLIGIBLE = 1e-12  # a penalty force below this (units per ft: a limit >= ~0.65 ft away) moves no reward digit
SQP_ITERS = 30
SQP_STEP_DONE = 1e-8  # max |step| in z at a KKT point: the reward moves by ~|H| step^2, nothing
SQP_PRED_DONE = 1e-13  # ... or the QP promises less than this decrease of f (normalised units)
SQP_PRED_TAKEN = 1e-10  # ... or a whole step just taken from a feasible point promised less than this, and every
#                         limit holds after it (the tail of a linearly converging SQP: see sqp_one)
SQP_LOCAL = 1e-4  # a step this short is taken whole (the l1 merit's Maratos effect would reject it)
AUG_GAIN = 100.0  # the augmentation, per unit normal, in units of H's largest diagonal entry (10 was enough
#                   where a reduced Hessian's smallest eigenvalue was 1.8e-5 of it; 100 keeps B's condition ~4e7)
RETRY_AUG_GAIN = 1000.0  # a second SQP, from the same start, where the first did not converge: a large negative
#                          eigenvalue of H_L in the span of the held limits needs more (docs/decisions.md)


@njit(cache=True)
def limit_values(z, goal, c):
    """c (NC,) in ft, <= 0 where the limit holds: |x_t| - X_LIM (t = 1..T), the distance past the
    lane-end band, and H_SCALE times the heading's distance past its band (the penalty's units)."""
    s = np.empty((T + 1, 5))
    rollout_one(z, s)
    _limits_of_states(s, goal, c)


@njit(cache=True)
def _limits_of_states(s, goal, c):
    """limit_values of rolled-out states s (T+1, 5)."""
    for t in range(1, T + 1):
        c[t - 1] = abs(s[t, 0]) - X_LIM
    x = s[T, 0]
    lane = LW if goal == 0 else min(max(LW * math.floor(x / LW + 0.5), -LW), LW)
    c[T] = abs(x - lane) - BAND
    c[T + 1] = H_SCALE * (abs(s[T, 2] - H0) - H_BAND)


@njit(cache=True)
def true_objective(z, ox, oy, goal, w):
    """w . phi_raw(z): F without the limits' terms (normalised reward units, sign flipped)."""
    f = np.empty(5)
    features_one(z, ox, oy, goal, f)
    return w[0] * f[0] + w[1] * f[1] + w[2] * f[2] + w[3] * f[3] + w[4] * f[4]


@njit(cache=True)
def true_objective_and_limits(z, ox, oy, goal, w, c, trace=None):
    """true_objective, and limit_values into c (NC,), from one rollout (the same bits as the two);
    trace: see kernels.trace_buffer (the penalty's columns are not written)."""
    s = np.empty((T + 1, 5))
    rollout_one(z, s, trace)
    _limits_of_states(s, goal, c)
    f = np.empty(5)
    features_of_states(s, ox, oy, goal, f, trace)
    return w[0] * f[0] + w[1] * f[1] + w[2] * f[2] + w[3] * f[3] + w[4] * f[4]


@njit(cache=True)
def limit_jacobian(z, goal, c, A):
    """c (NC,) as limit_values and A (NC, NV) = dc/dz (flat z), from the forward sensitivities of the
    Lagrangian's own pass (kernels._forward: the SQP reads them there; the objective's weights play no
    part in them, so none are given)."""
    work = workspace()
    no_car = np.zeros(T + 1)
    _forward(z, no_car, no_car, goal, np.zeros(5), np.zeros(NC), True, np.empty(NV), work, trace_buffer(), False)
    _jacobian_of_states(work[0], work[1], goal, c, A)


@njit(cache=True)
def _jacobian_of_states(S, Jall, goal, c, A):
    """limit_jacobian from the states S (T+1, 5) and sensitivities Jall (T+1, 5, NV) of a forward pass
    (kernels.workspace: the Lagrangian's pass has them already)."""
    for t in range(T):
        x = S[t + 1, 0]
        c[t] = abs(x) - X_LIM
        A[t, :] = (1.0 if x > 0.0 else -1.0) * Jall[t + 1, 0, :]
    x, h = S[T, 0], S[T, 2]
    lane = LW if goal == 0 else min(max(LW * math.floor(x / LW + 0.5), -LW), LW)
    c[T] = abs(x - lane) - BAND
    A[T, :] = (1.0 if x > lane else -1.0) * Jall[T, 0, :]
    c[T + 1] = H_SCALE * (abs(h - H0) - H_BAND)
    A[T + 1, :] = (H_SCALE if h > H0 else -H_SCALE) * Jall[T, 2, :]


@njit(cache=True)
def sqp_one(z, ox, oy, goal, w, lam, maxiter, feas_tol, z_best, f_start, aug_gain=AUG_GAIN):
    """Sequential quadratic programming from a feasible z near the constrained optimum (the penalty's
    answer), z (K, 2) in place, lam (NC,) multipliers (in: the penalty's forces; out: the final ones).

    Each iteration: the Lagrangian's exact Hessian H_L (kernels, limits' terms lam . c), made positive
    definite by adding r A_i' A_i for the limits with lam_i > 0 (which changes nothing on their null
    space) and, if needed, a diagonal shift; the QP  min 1/2 p' B p + grad f' p  s.t.  c + A p <= 0 and
    the box, by qp_solve; a full step where it lowers the l1 merit f + nu sum max(0, c) or is short,
    else halved.  True when the step is <= SQP_STEP_DONE with every limit holding to feas_tol: a KKT
    point with the QP's multipliers lam >= 0; or when a whole step from a feasible point promised at most
    SQP_PRED_TAKEN and every limit holds after it (where the SQP converges only linearly, the next QP
    would confirm it many iterations later).  z_best (K, 2) gets the best iterate, under w . phi_raw, at which
    every limit held to feas_tol (z itself if none did); f_start is w . phi_raw at the start.  Returns
    (converged, iterations, w . phi_raw at z_best).  Every point's objective and limits come from one
    rollout, and the limits' Jacobian from the Lagrangian's own forward pass."""
    zf = z.reshape(NV)
    c = np.empty(NC)
    A = np.empty((NC, NV))
    g = np.empty(NV)
    H = np.empty((NV, NV))
    B = np.empty((NV, NV))
    B0 = np.empty((NV, NV))
    Ginv = np.empty((NV, NV))
    m = NC + 2 * NV
    N = np.zeros((m, NV))
    bq = np.empty(m)
    p = np.empty(NV)
    u = np.empty(m)
    active = np.zeros(m, np.bool_)
    zt = np.empty(NV)
    ct = np.empty(NC)
    lam_pos = np.empty(NC)
    # The limits active in the last QP are augmented in the next QP's Hessian (as are the controls
    # it held on their bounds: active[NC + ...]).  The term r (A_i p)^2 / |A_i|^2 vanishes with p,
    # so it moves no KKT point, but it makes B positive definite where only the reduced Hessian is.
    # (Augmenting also the limits within 1e-3 ft of theirs left 3x more pairs unconverged.)
    held = np.zeros(NC, np.bool_)
    work = workspace()
    trace = trace_buffer()  # the transcendentals at z, once a line search has evaluated it
    z_best[:, :] = z
    f_best = f_z = f_start  # f_z: w . phi_raw at z
    for it in range(maxiter):
        for i in range(NC):
            lam_pos[i] = max(lam[i], 0.0)
        # grad L (kernels.lagrangian_grad_hess), from the trace once a line search has evaluated z
        _forward(z, ox, oy, goal, w, lam_pos, True, g, work, trace, it > 0)
        _backward(ox, oy, goal, w, lam_pos, True, work, H)  # ... hess L
        _jacobian_of_states(work[0], work[1], goal, c, A)
        for j in range(NV):  # grad f = grad L - A' lam
            for i in range(NC):
                g[j] -= A[i, j] * lam_pos[i]
        r_aug = 1.0
        for j in range(NV):
            r_aug = max(r_aug, abs(H[j, j]))
        r_aug *= aug_gain
        B0[:, :] = H
        for i in range(NC):
            if held[i]:
                f_i = r_aug / max(1.0, _row_norm2(A, i))
                Ai = A[i]  # row views: no 2-d index arithmetic in the inner loop (1.5x)
                for a_ in range(NV):
                    c_a, Ba = f_i * Ai[a_], B0[a_]
                    for b_ in range(NV):
                        Ba[b_] += c_a * Ai[b_]
        for a_ in range(NV):
            if active[NC + 2 * a_] or active[NC + 2 * a_ + 1]:  # a control held on its bound
                B0[a_, a_] += r_aug
        shift = 0.0
        ok = False
        for _attempt in range(40):
            B[:, :] = B0
            for a_ in range(NV):
                B[a_, a_] += shift
            if _inverse_spd(B, NV, Ginv):
                ok = True
                break
            shift = max(1e-12 * r_aug, 10.0 * shift)
        if not ok:
            return False, it, f_best
        for i in range(NC):  # c + A p <= 0  as  (-A_i) . p >= c_i
            N[i, :] = -A[i, :]
            bq[i] = c[i]
        for j in range(NV):  # -1 <= z + p <= 1
            N[NC + 2 * j, j] = 1.0
            bq[NC + 2 * j] = -1.0 - zf[j]
            N[NC + 2 * j + 1, j] = -1.0
            bq[NC + 2 * j + 1] = zf[j] - 1.0
        if not qp_solve(Ginv, g, N, bq, m, p, u, active):
            return False, it, f_best
        step = 0.0
        for j in range(NV):
            step = max(step, abs(p[j]))
        viol = 0.0
        for i in range(NC):
            viol = max(viol, c[i])
        for i in range(NC):
            lam[i] = u[i]
            held[i] = active[i]
        # the QP model's decrease: how much f the step promised (a flat valley along several nearly
        # dependent active limits gives long steps that promise nothing: converged in f all the same)
        pred = 0.0
        for a_ in range(NV):
            bp = 0.0
            for b_ in range(NV):
                bp += B[a_, b_] * p[b_]
            pred -= p[a_] * (g[a_] + 0.5 * bp)
        if (step <= SQP_STEP_DONE or pred <= SQP_PRED_DONE) and viol <= feas_tol:
            z_best[:, :] = z
            return True, it, f_z
        # the merit's weight on violation: above the multipliers (exact penalty) but of their size;
        # weight 1 (normalised units per ft, multipliers ~1e-4) rejected nearly every full step
        nu = 1e-8
        for i in range(NC):
            nu = max(nu, 2.0 * u[i])
        merit = f_z + nu * _excess(c)
        alpha = 1.0
        for _ls in range(30):
            for j in range(NV):
                zt[j] = min(1.0, max(-1.0, zf[j] + alpha * p[j]))
            f_t = true_objective_and_limits(zt.reshape(z.shape), ox, oy, goal, w, ct, trace)
            if f_t + nu * _excess(ct) <= merit or alpha * step <= SQP_LOCAL:
                break
            if alpha == 1.0 and _second_order_correction(zf, p, Ginv, A, active, ct, zt):
                # the full step's curvature pushed the active limits off (Maratos): corrected back onto
                # them along the QP's metric, it is taken if the merit then falls
                f_t = true_objective_and_limits(zt.reshape(z.shape), ox, oy, goal, w, ct, trace)
                if f_t + nu * _excess(ct) <= merit:
                    break
            alpha *= 0.5
        zf[:] = zt
        f_z = f_t
        feasible = ct.max() <= feas_tol
        if alpha == 1.0 and viol <= feas_tol and 0.0 <= pred <= SQP_PRED_TAKEN and feasible:
            z_best[:, :] = z
            return True, it + 1, f_z
        if feasible and f_z < f_best:
            f_best = f_z
            z_best[:, :] = z
    return False, maxiter, f_best


@njit(cache=True)
def _second_order_correction(zf, p, Ginv, A, active, ct, zt):
    """zt = z + p + q with q = -G^-1 A_W' (A_W G^-1 A_W')^-1 c_W(z + p): the step corrected so the
    limits active in the QP hold again to second order (A_W at z, c_W at z + p, ct).  False if no
    limit is active or the system is singular."""
    n = zf.shape[0]
    rows = np.empty(NC, np.int64)
    q = 0
    for i in range(NC):
        if active[i]:
            rows[q] = i
            q += 1
    if q == 0:
        return False
    GA = np.empty((n, q))
    for a_ in range(q):
        for j in range(n):
            v = 0.0
            for k in range(n):
                v += Ginv[j, k] * A[rows[a_], k]
            GA[j, a_] = v
    S = np.empty((q, q))
    r = np.empty(q)
    y = np.empty(q)
    _normal_gram(A, rows, q, GA, S)
    for a_ in range(q):
        r[a_] = ct[rows[a_]]
    if not _cholesky_solve(S, r, y):
        return False
    for j in range(n):
        v = zf[j] + p[j]
        for a_ in range(q):
            v -= GA[j, a_] * y[a_]
        zt[j] = min(1.0, max(-1.0, v))
    return True


@njit(cache=True)
def _row_norm2(A, i):
    v = 0.0
    for j in range(A.shape[1]):
        v += A[i, j] * A[i, j]
    return v


@njit(cache=True)
def _excess(c):
    """sum_i max(0, c_i): how far past the limits, in total (ft)."""
    v = 0.0
    for i in range(c.shape[0]):
        v += max(0.0, c[i])
    return v


@njit(cache=True)
def constrained_one(z, ox, oy, goal, w, maxiter, tol, feas_tol, from_penalty_optimum):
    """The optimum of w . phi_raw with the world's limits as hard constraints, from z (in place).

    1. Projected Newton on the soft penalty finds the basin (skipped if from_penalty_optimum: z is
       already the penalty's optimum, to the stored precision).  If no limit exerts a force above
       LAM_NEGLIGIBLE there, that is the constrained optimum too (status 0).
    2. sqp_one from there, the penalty's forces as first multipliers, and again with RETRY_AUG_GAIN if
       it does not converge.  Status 1: it reached a KKT point (sqp_one's test, every limit holding to
       feas_tol) no worse than the penalty's answer.  Status 2: otherwise; the better of the penalty's
       (feasible) answer and the SQPs' best feasible iterate is kept, and nothing claimed.
    Returns (w . phi_raw at the answer, Newton and SQP iterations, status)."""
    lam = np.zeros(NC)
    it = 0
    if not from_penalty_optimum:
        _, it = newton_one(z, ox, oy, goal, w, maxiter, tol)
    c = np.empty(NC)
    f_pen = true_objective_and_limits(z, ox, oy, goal, w, c)
    pressed = False
    for i in range(NC):
        lam[i] = overshoot_penalty(c[i])[1]
        pressed = pressed or lam[i] > LAM_NEGLIGIBLE
    if not pressed:
        return f_pen, it, 0
    z_best = np.empty_like(z)
    f_kept, z_kept = f_pen, z.copy()
    for aug_gain in (AUG_GAIN, RETRY_AUG_GAIN):
        zs = z.copy()
        ok, its, f = sqp_one(zs, ox, oy, goal, w, lam.copy(), SQP_ITERS, feas_tol, z_best, f_pen, aug_gain)
        it += its
        if ok and f <= f_pen + 1e-12:
            z[:, :] = z_best
            return f, it, 1
        if f < f_kept:  # not converged, but a feasible iterate beat what is kept so far
            f_kept = f
            z_kept[:, :] = z_best
    z[:, :] = z_kept
    return f_kept, it, 2


@njit(parallel=True, cache=True)
def constrained_batch(z, ox, oy, goal, w, maxiter, tol, feas_tol, from_penalty_optimum, F_out, it_out, status_out):
    """constrained_one on every problem (in parallel, striped as newton.solve_batch). z (B, K, 2) in place."""
    n = z.shape[0]
    for s in prange(STRIPES):
        for b in range(s, n, STRIPES):
            F, it, st = constrained_one(z[b], ox[b], oy[b], goal[b], w[b], maxiter, tol, feas_tol,
                                        from_penalty_optimum)
            F_out[b] = F
            it_out[b] = it
            status_out[b] = st


@njit(parallel=True, cache=True)
def limits_batch(z, goal, out):
    """out (B, NC) = limit_values of every z (B, K, 2)."""
    for b in prange(z.shape[0]):
        limit_values(z[b], goal[b], out[b])


numba_config.CACHE_DIR = _user_cache_dir
