"""The optimum with the world's limits as hard constraints (issue 22), one trajectory at a time.

The soft penalty of :mod:`teaching.kernels` finds the basins, but its minimiser lies a little inside
each limit it presses against (0.16-0.36 ft from |x| = 12 in the planner-9 demo table, up to 1.4e-3
normalised reward units off the constrained optimum).  From that point, :func:`constrained_one`

1. runs a few loose rounds of the augmented Lagrangian (Powell-Hestenes-Rockafellar; the AL term is
   kernels.limit_term with rho > 0) to learn which limits are active, then
2. polishes with Newton on the KKT conditions of those limits (:func:`kkt_polish`), which converges
   quadratically to rounding level; where that fails, the augmented Lagrangian is run to convergence.

Limits (NC = T + 2 values c <= 0, in ft; :func:`limit_values`): |x_t| <= x_limit at t = 1..T; the
lane-end band |x_T - lane| <= lane_end_band; H_SCALE (|h_T - pi/2| - heading_end_band) for the end
heading.  The controls' box [-1, 1] is kept by projection, as in kernels.newton_one.
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
    LW,
    NC,
    NV,
    STRIPES,
    WORLD_CACHE_DIR,
    X_LIM,
    T,
    _cholesky_solve,
    al_objective_grad_hess,
    features_one,
    newton_one,
    overshoot_penalty,
    rollout_one,
)

_user_cache_dir = numba_config.CACHE_DIR
numba_config.CACHE_DIR = WORLD_CACHE_DIR  # these kernels freeze the world's constants too (see teaching.kernels)

LAM_NEGLIGIBLE = 1e-12  # a penalty force below this (units per ft: a limit >= ~0.65 ft away) moves no reward digit
RHO_START, RHO_MAX = 1e4, 1e7  # the augmented Lagrangian's stiffness (units per ft^2)
AL_ROUNDS = 12
AL_ROUNDS_LOOSE, AL_ITERS_LOOSE, AL_TOL_LOOSE, AL_FEAS_LOOSE = 3, 30, 1e-5, 1e-4  # to find the active limits
KKT_ITERS = 20
KKT_MAX_STEP = 0.05  # largest Newton-KKT step (in z) taken as still local


@njit(cache=True)
def limit_values(z, goal, c):
    """c (NC,) in ft, <= 0 where the limit holds: |x_t| - X_LIM (t = 1..T), the distance past the
    lane-end band, and H_SCALE times the heading's distance past its band (the penalty's units)."""
    s = np.empty((T + 1, 5))
    rollout_one(z, s)
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
def augmented_lagrangian(z, ox, oy, goal, w, lam, rho, rounds, maxiter, tol, feas_tol):
    """Rounds of the augmented Lagrangian from z (in place) and multipliers lam (NC,, in place):
    each minimises the AL function by newton_one and sets lam = max(0, lam + rho c); rho grows
    tenfold when the limits' residual max_i |max(c_i, -lam_i / rho)| (ft) did not fall fourfold.
    Returns (Newton iterations, residual, True if the last round's Newton converged (its projected
    gradient below tol, not a failed line search) and the
    residual is <= feas_tol: then z is a KKT point with multipliers lam)."""
    c = np.empty(NC)
    it, resid, last = 0, np.inf, np.inf
    for _round in range(rounds):
        _, its, converged = newton_one(z, ox, oy, goal, w, maxiter, tol, lam, rho)
        it += its
        limit_values(z, goal, c)
        resid = 0.0
        for i in range(NC):
            resid = max(resid, abs(max(c[i], -lam[i] / rho)))
            lam[i] = max(0.0, lam[i] + rho * c[i])
        if resid <= feas_tol and converged:
            return it, resid, True
        if resid > 0.25 * last:
            rho = min(10.0 * rho, RHO_MAX)
        last = resid
    return it, resid, False


@njit(cache=True)
def constrained_one(z, ox, oy, goal, w, maxiter, tol, feas_tol):
    """The optimum of F with the world's limits as hard constraints, from z (modified in place).

    1. Projected Newton on the soft penalty (it finds the basin; its minimiser lies a little inside
       each limit it presses against).  If no limit exerts a force > LAM_NEGLIGIBLE there, that
       is the constrained optimum too, and we stop.
    2. A few loose rounds of the augmented Lagrangian identify the limits that are active.
    3. kkt_polish: Newton on the KKT conditions with those limits, to rounding level.
    4. If that fails, or ends worse than the penalty's (feasible) answer, the augmented Lagrangian
       run to convergence; if that fails too, the penalty's answer is kept (status 2).
    Returns (w . phi_raw at the answer, Newton iterations, limits' residual in ft, status:
    0 no limit pressed, 1 exact (KKT to feas_tol), 2 kept the penalty's answer)."""
    lam = np.zeros(NC)
    _, it, _ = newton_one(z, ox, oy, goal, w, maxiter, tol, lam, 0.0)
    c = np.empty(NC)
    limit_values(z, goal, c)
    pressed = False
    for i in range(NC):
        pressed = pressed or overshoot_penalty(c[i])[1] > LAM_NEGLIGIBLE
    f_pen = true_objective(z, ox, oy, goal, w)
    if not pressed:
        return f_pen, it, 0.0, 0
    za = z.copy()
    its, resid, _ = augmented_lagrangian(za, ox, oy, goal, w, lam, RHO_START, AL_ROUNDS_LOOSE, AL_ITERS_LOOSE,
                                         AL_TOL_LOOSE, AL_FEAS_LOOSE)
    it += its
    zk = za.copy()
    lk = lam.copy()
    if kkt_polish(zk, ox, oy, goal, w, lk, KKT_ITERS, feas_tol):
        f = true_objective(zk, ox, oy, goal, w)
        if f <= f_pen + 1e-12:
            z[:, :] = zk
            return f, it, _residual(zk, goal, lk), 1
    its, resid, ok = augmented_lagrangian(za, ox, oy, goal, w, lam, RHO_START, AL_ROUNDS, maxiter, tol, feas_tol)
    it += its
    if ok:
        f = true_objective(za, ox, oy, goal, w)
        if f <= f_pen + 1e-12:
            z[:, :] = za
            return f, it, resid, 1
    return f_pen, it, 0.0, 2


@njit(cache=True)
def _residual(z, goal, lam):
    """max_i |max(c_i, -lam_i)| (ft): feasibility and complementarity of z with multipliers lam."""
    c = np.empty(NC)
    limit_values(z, goal, c)
    r = 0.0
    for i in range(NC):
        r = max(r, abs(max(c[i], -lam[i])))
    return r


@njit(parallel=True, cache=True)
def constrained_batch(z, ox, oy, goal, w, maxiter, tol, feas_tol, F_out, it_out, resid_out, status_out):
    """constrained_one on every problem (in parallel, striped as solve_batch). z (B, K, 2) in place."""
    n = z.shape[0]
    for s in prange(STRIPES):
        for b in range(s, n, STRIPES):
            F, it, r, st = constrained_one(z[b], ox[b], oy[b], goal[b], w[b], maxiter, tol, feas_tol)
            F_out[b] = F
            it_out[b] = it
            resid_out[b] = r
            status_out[b] = st


@njit(cache=True)
def _solve_spd(A, b, x, n):
    """x[:n] = A[:n, :n]^-1 b[:n] by Cholesky, A shifted along its diagonal until positive definite.
    Returns the shift used (0.0 if none), -1.0 if none worked."""
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(A[i, i]))
    mu = 0.0
    B = np.empty((n, n))
    for _attempt in range(40):
        for i in range(n):
            for j in range(n):
                B[i, j] = A[i, j]
            B[i, i] += mu
        if _cholesky_solve(B, b[:n].copy(), x[:n]):
            return mu
        mu = max(1e-14 * (scale + 1e-300), 10.0 * mu)
    return -1.0


@njit(cache=True)
def _independent_solve(S, r, x, m, lam, rows):
    """x[:m] solving S x = r on a maximal set of linearly independent working limits (S = A H^-1 A^T
    is singular where limits are redundant: a car running along x = 12 for several steps meets them
    all once it is straight), taken greedily by decreasing multiplier; the others get x = 0
    (they hold implicitly, and the next iteration checks them).  An incremental Cholesky."""
    order = np.argsort(-np.array([lam[rows[k]] for k in range(m)]))
    L = np.zeros((m, m))
    kept = np.empty(m, np.int64)
    n = 0
    for k in order:
        for a in range(n):
            j = kept[a]
            v = S[k, j]
            for b in range(a):
                v -= L[k, kept[b]] * L[j, kept[b]]
            L[k, j] = v / L[j, j]
        d = S[k, k]
        for a in range(n):
            d -= L[k, kept[a]] ** 2
        if d > 1e-10 * S[k, k] and d > 0.0:
            L[k, k] = math.sqrt(d)
            kept[n] = k
            n += 1
        else:
            for a in range(n):
                L[k, kept[a]] = 0.0
    y = np.zeros(m)
    for a in range(n):
        k = kept[a]
        v = r[k]
        for b in range(a):
            v -= L[k, kept[b]] * y[kept[b]]
        y[k] = v / L[k, k]
    x[:m] = 0.0
    for a in range(n - 1, -1, -1):
        k = kept[a]
        v = y[k]
        for b in range(a + 1, n):
            v -= L[kept[b], k] * x[kept[b]]
        x[k] = v / L[k, k]


@njit(cache=True)
def kkt_polish(z, ox, oy, goal, w, lam, maxiter, feas_tol):
    """Newton on the KKT conditions from a point near the constrained optimum; z (K, 2) in place,
    lam (NC,) the multipliers (in: the augmented Lagrangian's; out: the final ones).

    The working set starts as the limits with lam > 0 or c > -feas_tol.  Each iteration solves the
    equality-constrained Newton system  H_L p + A^T lam' = -grad f,  A p = -c  on the free controls
    (H_L the Lagrangian's exact Hessian, A the working limits' gradients) by a Cholesky of
    H_L + r A^T A and of the Schur complement; limits whose new multiplier is negative leave the set
    and violated ones join it.  True when the step is at rounding level, every working limit holds
    with equality and every other limit holds (to feas_tol), and lam >= 0: a KKT point."""
    zf = z.reshape(NV)
    c = np.empty(NC)
    limit_values(z, goal, c)
    work = np.zeros(NC, np.bool_)
    for i in range(NC):
        work[i] = lam[i] > 0.0 or c[i] > -feas_tol
    g = np.empty(NV)
    H = np.empty((NV, NV))
    gi = np.empty(NV)
    Hd = np.empty((NV, NV))
    A = np.zeros((NC, NV))
    unit = np.zeros(NC)
    zero_w = np.zeros(5)
    idx = np.empty(NV, np.int64)
    rows = np.empty(NC, np.int64)
    Hs = np.empty((NV, NV))
    rhs = np.empty(NV)
    u = np.empty(NV)
    col = np.empty(NV)
    gfree = np.empty(NV)
    Y = np.empty((NC, NV))
    S = np.empty((NC, NC))
    r = np.empty(NC)
    lnew = np.empty(NC)
    for _it in range(maxiter):
        lam_w = np.where(work, lam, 0.0)
        al_objective_grad_hess(z, ox, oy, goal, w, lam_w, -1.0, g, H, True)  # grad and Hessian of L
        m = 0
        for i in range(NC):
            if work[i]:
                unit[i] = 1.0
                al_objective_grad_hess(z, ox, oy, goal, zero_w, unit, -1.0, gi, Hd, False)  # grad c_i
                unit[i] = 0.0
                A[m, :] = gi
                rows[m] = i
                m += 1
        nf = 0
        for j in range(NV):
            # a control on its bound stays there while the Lagrangian pushes it outwards
            if (zf[j] >= 1.0 and g[j] < 0.0) or (zf[j] <= -1.0 and g[j] > 0.0):
                continue
            gf = g[j]  # grad f = grad L - A^T lam
            for a in range(m):
                gf -= A[a, j] * lam_w[rows[a]]
            idx[nf] = j
            gfree[nf] = gf
            nf += 1
        r_aug = 1.0
        for a in range(nf):
            r_aug = max(r_aug, abs(H[idx[a], idx[a]]))
        for a in range(nf):
            for b in range(nf):
                v = H[idx[a], idx[b]]
                for k in range(m):
                    v += r_aug * A[k, idx[a]] * A[k, idx[b]]
                Hs[a, b] = v
            v = -gfree[a]
            for k in range(m):
                v -= r_aug * A[k, idx[a]] * c[rows[k]]
            rhs[a] = v
        if _solve_spd(Hs, rhs, u, nf) < 0.0:
            return False
        for k in range(m):
            for a in range(nf):
                rhs[a] = A[k, idx[a]]
            if _solve_spd(Hs, rhs, col, nf) < 0.0:
                return False
            Y[k, :nf] = col[:nf]
        for k in range(m):
            v = c[rows[k]]
            for a in range(nf):
                v += A[k, idx[a]] * u[a]
            r[k] = v
            for q in range(m):
                v = 0.0
                for a in range(nf):
                    v += A[k, idx[a]] * Y[q, a]
                S[k, q] = v
        if m:
            _independent_solve(S, r, lnew, m, lam_w, rows)
        step = 0.0
        for a in range(nf):
            v = u[a]
            for k in range(m):
                v -= Y[k, a] * lnew[k]
            j = idx[a]
            zn = min(1.0, max(-1.0, zf[j] + v))
            step = max(step, abs(zn - zf[j]))
            zf[j] = zn
        if step > KKT_MAX_STEP:  # not near a KKT point of this working set: let the AL go on
            return False
        lam[:] = 0.0
        neg = False
        for k in range(m):
            lam[rows[k]] = lnew[k]
            neg = neg or lnew[k] < 0.0
        limit_values(z, goal, c)
        viol = 0.0
        added = False
        for i in range(NC):
            viol = max(viol, abs(c[i]) if work[i] else c[i])
            if not work[i] and c[i] > feas_tol:
                work[i] = True
                added = True
        if neg:
            for i in range(NC):
                if work[i] and lam[i] < 0.0:
                    work[i] = False
                    lam[i] = 0.0
        if step <= 1e-11 and viol <= feas_tol and not neg and not added:
            return True
    return False


@njit(parallel=True, cache=True)
def limits_batch(z, goal, out):
    """out (B, NC) = limit_values of every z (B, K, 2)."""
    for b in prange(z.shape[0]):
        limit_values(z[b], goal[b], out[b])


numba_config.CACHE_DIR = _user_cache_dir
