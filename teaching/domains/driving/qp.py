"""The SQP's quadratic programs: Goldfarb and Idnani's dual active-set method (:func:`qp_solve`)
for a small dense QP with linear inequality constraints, and the linear algebra it needs.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.core import config as numba_config

from .kernels import KERNEL_CACHE_DIR
from .newton import _cholesky_solve, cholesky

_user_cache_dir = numba_config.CACHE_DIR
numba_config.CACHE_DIR = KERNEL_CACHE_DIR  # kernels.py says why

QP_TOL = 1e-13  # ft (per unit normal): a linearised limit violated by less is held
QP_DEP = 1e-8  # share of a normal (G^-1 metric) outside the active ones' span below which it depends on them


@njit(cache=True)
def _inverse_spd(G, n, out):
    """out = G^-1 for SPD G (n, n), by one Cholesky factorisation; False if G is not positive definite.

    Two columns of L^-1, and two entries of each row of L^-T L^-1, are worked side by side: every
    entry is the same sum in the same order as one at a time, but the two are independent chains
    the CPU overlaps (as in newton.cholesky)."""
    L = np.zeros((n, n))
    if not cholesky(G, L):
        return False
    Li = np.zeros((n, n))  # L^-1, lower triangular: Li[i, j] = -(sum_{k=j}^{i-1} L[i, k] Li[k, j]) / L[i, i]
    for j in range(0, n - 1, 2):
        j2 = j + 1
        Li[j, j] = 1.0 / L[j, j]
        Li[j2, j2] = 1.0 / L[j2, j2]
        Li[j2, j] = (0.0 - L[j2, j] * Li[j, j]) / L[j2, j2]
        for i in range(j2 + 1, n):
            s = 0.0 - L[i, j] * Li[j, j]
            s2 = 0.0
            for k in range(j2, i):
                s -= L[i, k] * Li[k, j]
                s2 -= L[i, k] * Li[k, j2]
            Li[i, j] = s / L[i, i]
            Li[i, j2] = s2 / L[i, i]
    if n % 2:
        Li[n - 1, n - 1] = 1.0 / L[n - 1, n - 1]
    for i in range(n):  # G^-1 = L^-T L^-1: out[i, j] = sum_{k=i}^{n-1} Li[k, i] Li[k, j] for j <= i
        for j in range(0, i, 2):
            s = 0.0
            s2 = 0.0
            for k in range(i, n):
                s += Li[k, i] * Li[k, j]
                s2 += Li[k, i] * Li[k, j + 1]
            out[i, j] = s
            out[j, i] = s
            out[i, j + 1] = s2
            out[j + 1, i] = s2
        if i % 2 == 0:
            s = 0.0
            for k in range(i, n):
                s += Li[k, i] * Li[k, i]
            out[i, i] = s
    return True


@njit(cache=True)
def _normal_gram(N, rows, q, GN, out):
    """out[:q, :q] = N_rows G^-1 N_rows' for the q normals N[rows[:q]], given GN[:, :q] = G^-1 N_rows'
    (the Schur complement of the active limits in the QP's metric)."""
    for a_ in range(q):
        for b_ in range(q):
            v = 0.0
            for j in range(N.shape[1]):
                v += N[rows[a_], j] * GN[j, b_]
            out[a_, b_] = v


@njit(cache=True)
def _dot_row(N, i, lo, hi, v, s=0.0):
    """s + N[i] . v, added term by term from s, over the columns lo[i]:hi[i] where row i can be
    non-zero: the same bits as the full sum (the terms left out are exact zeros)."""
    for j in range(lo[i], hi[i]):
        s += N[i, j] * v[j]
    return s


@njit(cache=True)
def qp_solve(Ginv, a, N, b, m, x, u, active):
    """Goldfarb and Idnani's dual active-set method for  min 1/2 x' G x + a' x  s.t.  N_i . x >= b_i
    (i < m), given Ginv = G^-1 (n, n), G positive definite.  x (n,) and u (m,) (the multipliers, >= 0)
    are filled; active (m,) bool marks the active constraints.  Starting from the unconstrained
    minimum it adds the most violated constraint, moving primal and dual variables together and
    dropping an active constraint whenever its multiplier would turn negative; a constraint whose
    normal depends on the active ones is reached by dropping one (so the active normals stay
    independent: redundant limits need no care).  Returns False if the constraints are infeasible
    or it did not finish in its iteration budget.

    The normals are sparse (a box bound touches one variable, the limit at step t only the knots
    before it), so every product with a row runs over the columns where it can be non-zero, and the
    active normals' Gram matrix in the G^-1 metric is kept up to date as constraints join and leave
    rather than formed again at every step: each entry is the same sum as before, so the same bits."""
    n = Ginv.shape[0]
    for i in range(n):
        v = 0.0
        for j in range(n):
            v -= Ginv[i, j] * a[j]
        x[i] = v
    u[:m] = 0.0
    active[:m] = False
    lo, hi, norm = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m)
    for i in range(m):
        lo[i], hi[i] = n, 0
        nn = 0.0
        for j in range(n):
            if N[i, j] != 0.0:
                lo[i], hi[i] = min(lo[i], j), j + 1
            nn += N[i, j] * N[i, j]
        norm[i] = math.sqrt(nn) + 1e-300
        hi[i] = max(hi[i], lo[i])
    act = np.empty(n, np.int64)  # indices of the active constraints, in order
    q = 0
    GN = np.empty((n, n))  # Ginv N_k' for the active k (columns)
    Mq = np.empty((n, n))  # Mq[a, b] = N_act[a] . GN[:, b], the active normals' Gram matrix
    zdir = np.empty(n)
    r = np.empty(n)
    w1 = np.empty(n)
    gn = np.empty(n)
    for _outer in range(4 * (m + n)):
        # the most violated constraint (relative to its normal's size)
        worst, p = 0.0, -1
        for i in range(m):
            if active[i]:
                continue
            s = _dot_row(N, i, lo, hi, x, -b[i]) / norm[i]
            if s < worst - QP_TOL:
                worst, p = s, i
        if p < 0:
            return True
        for j in range(n):  # gn = Ginv N_p'
            v = 0.0
            for k in range(lo[p], hi[p]):
                v += Ginv[j, k] * N[p, k]
            gn[j] = v
        gg = _dot_row(N, p, lo, hi, gn)
        u_p = 0.0
        for _inner in range(n + 2):
            # r = (Na Ginv Na')^-1 Na Ginv n_p ; z = Ginv n_p - Ginv Na' r
            if q:
                for a_ in range(q):
                    w1[a_] = _dot_row(N, act[a_], lo, hi, gn)
                if not _cholesky_solve(Mq[:q, :q].copy(), w1[:q].copy(), r[:q]):
                    return False
            for j in range(n):
                v = gn[j]
                for a_ in range(q):
                    v -= GN[j, a_] * r[a_]
                zdir[j] = v
            t1, l_ = np.inf, -1
            for a_ in range(q):
                if r[a_] > 0.0:
                    ratio = u[act[a_]] / r[a_]
                    if ratio < t1:
                        t1, l_ = ratio, a_
            zn = _dot_row(N, p, lo, hi, zdir)
            s = _dot_row(N, p, lo, hi, x, -b[p])
            # n_p' H n_p against n_p' G^-1 n_p: the share of n_p the active normals do not explain
            t2 = -s / zn if zn > QP_DEP * gg else np.inf
            t = min(t1, t2)
            if t == np.inf:
                return False
            if t2 < np.inf:
                for j in range(n):
                    x[j] += t * zdir[j]
            for a_ in range(q):
                u[act[a_]] -= t * r[a_]
            u_p += t
            if t == t2:  # full step: p joins the active set
                u[p] = u_p
                active[p] = True
                act[q] = p
                GN[:, q] = gn
                for a_ in range(q + 1):
                    Mq[a_, q] = _dot_row(N, act[a_], lo, hi, GN[:, q])
                    Mq[q, a_] = _dot_row(N, p, lo, hi, GN[:, a_])
                q += 1
                break
            # partial step: the constraint whose multiplier reached 0 leaves
            k_out = act[l_]
            active[k_out] = False
            u[k_out] = 0.0
            for a_ in range(l_, q - 1):
                act[a_] = act[a_ + 1]
                GN[:, a_] = GN[:, a_ + 1]
            for a_ in range(l_, q - 1):  # Mq without row and column l_
                Mq[a_, :q] = Mq[a_ + 1, :q]
            for a_ in range(l_, q - 1):
                Mq[:q - 1, a_] = Mq[:q - 1, a_ + 1]
            q -= 1
    return False


numba_config.CACHE_DIR = _user_cache_dir
