"""The planner's small dense linear algebra (newton.cholesky, newton._cholesky_solve, qp._inverse_spd).

They work two rows (or columns) at a time so the CPU can overlap two chains of arithmetic, and
promise that every entry is still the same sum in the same order as the textbook loop.  A table's
bytes depend on that promise, so it is checked to the bit against those loops written out plainly
in Python (IEEE doubles, one rounding per operation, as Numba compiles them without fastmath), and
for what the results mean against NumPy.
"""
import math

import numpy as np
import pytest

from teaching.domains.driving import newton, qp

SIZES = [1, 2, 3, 4, 7, 10, 20, 21]


def _textbook_cholesky(A):
    """Row by row: L[i, j] = (A[i, j] - sum_{k<j} L[i, k] L[j, k]) / L[j, j], k ascending."""
    n = len(A)
    L = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            s = float(A[i, j])
            for k in range(j):
                s -= L[i][k] * L[j][k]
            if i == j:
                if s <= 0.0:
                    return None
                L[i][i] = math.sqrt(s)
            else:
                L[i][j] = s / L[j][j]
    return np.array(L)


def _textbook_inverse(A):
    """L^-1 column by column, then G^-1 = L^-T L^-1 entry by entry, each sum from 0.0, k ascending."""
    L = _textbook_cholesky(A)
    n = len(A)
    Li = [[0.0] * n for _ in range(n)]
    for j in range(n):
        Li[j][j] = 1.0 / L[j, j]
        for i in range(j + 1, n):
            s = 0.0
            for k in range(j, i):
                s -= L[i, k] * Li[k][j]
            Li[i][j] = s / L[i, i]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(i + 1):
            s = 0.0
            for k in range(i, n):
                s += Li[k][i] * Li[k][j]
            out[i, j] = out[j, i] = s
    return out


def _spd(rng, n, condition):
    """A random SPD matrix with eigenvalues spread over `condition` decades."""
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    A = (Q * np.logspace(0, -condition, n)) @ Q.T
    return (A + A.T) / 2.0


def _bits(a):
    return np.ascontiguousarray(a, np.float64).view(np.int64)


@pytest.mark.parametrize("n", SIZES)
def test_the_cholesky_factor_and_solve_are_the_textbook_loops_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for condition in (0, 3, 8):
        A = _spd(rng, n, condition)
        L = np.zeros((n, n))
        assert newton.cholesky(A, L)
        ref = _textbook_cholesky(A)
        assert np.array_equal(_bits(np.tril(L)), _bits(ref))
        assert np.allclose(L @ L.T, A, rtol=0, atol=1e-12 * np.abs(A).max())
        b, x = rng.normal(size=n), np.empty(n)
        assert newton._cholesky_solve(A, b, x)
        assert np.allclose(A @ x, b, atol=1e-6 * np.abs(b).max() * 10.0 ** condition)


@pytest.mark.parametrize("n", SIZES)
def test_the_spd_inverse_is_the_textbook_loops_bit_for_bit(n):
    rng = np.random.default_rng(100 + n)
    for condition in (0, 3, 8):
        A = _spd(rng, n, condition)
        out = np.empty((n, n))
        assert qp._inverse_spd(A, n, out)
        assert np.array_equal(_bits(out), _bits(_textbook_inverse(A)))
        assert np.allclose(out @ A, np.eye(n), atol=1e-14 * 10.0 ** condition * n)


@pytest.mark.parametrize("n", [2, 5, 20])
def test_a_matrix_that_is_not_positive_definite_is_refused(n):
    rng = np.random.default_rng(7)
    A = _spd(rng, n, 2)
    A[n - 1, n - 1] = -1.0  # the last pivot turns negative, whichever pair of rows it falls in
    assert not newton.cholesky(A, np.zeros((n, n)))
    assert not newton._cholesky_solve(A, np.ones(n), np.empty(n))
    assert not qp._inverse_spd(A, n, np.empty((n, n)))
    B = _spd(rng, n, 2)
    B[0, 0] = 0.0  # the first
    assert not newton.cholesky(B, np.zeros((n, n)))
