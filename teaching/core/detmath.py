"""Transcendental functions whose results do not depend on the CPU (docs/decisions.md, "Reproducible tables").

A table's content hash must be the same on every machine, but the usual routes to exp, sin or
10**u are dispatched on the processor: NumPy picks AVX-512 or AVX2 loops for ``np.power`` and
``np.log10``, and glibc's libm (which Numba's compiled ``math.exp``/``math.sin`` call) picks FMA or
non-FMA variants at load time.  Each is accurate to about an ulp, but not the *same* ulp: on one
machine the demo preset built three different hashes this way.

So what a table's bytes depend on goes through this module instead:

* :func:`exp`, :func:`sincos`, :func:`tan`, :func:`softplus_sigmoid` - Numba functions
  built from +, -, *, / and ``ldexp``/``frexp`` alone (each correctly rounded by IEEE 754, or
  exact), in a fixed order, with no fused multiply-add (Numba contracts only under fastmath).
  Range reduction by Cody and Waite's split constants, then Taylor polynomials long enough that
  the truncation is far below an ulp: about 1-2 ulp, the same bits everywhere.
* :func:`pow10` and :func:`log10` - correctly rounded, elementwise, through :mod:`decimal`
  (software arithmetic, 40 digits, then one rounding to float64): used where a few thousand values
  are needed (the candidate thetas, the planner's anchor order), never in a hot loop.

The split constants below were computed once at 80 decimal digits (see the tests, which check
them and each function against :mod:`decimal` references).
"""
from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np
from numba import njit

# pi/2 = PIO2_1 + PIO2_2 + PIO2_3, the first two with 33 significant bits, so k * PIO2_i is
# exact for |k| < 2**20 (|x| < 1.6e6 rad: far beyond any angle a domain needs).
PIO2_1 = float.fromhex("0x1.921fb54400000p+0")
PIO2_2 = float.fromhex("0x1.0b4611a600000p-34")
PIO2_3 = float.fromhex("0x1.3198a2e037073p-69")
INV_PIO2 = float.fromhex("0x1.45f306dc9c883p-1")
# ln 2 = LN2_HI + LN2_LO, LN2_HI with 32 significant bits (k * LN2_HI exact for |k| < 2**21).
LN2_HI = float.fromhex("0x1.62e42ff000000p-1")
LN2_LO = float.fromhex("-0x1.718432a1b0e26p-35")
INV_LN2 = float.fromhex("0x1.71547652b82fep+0")
EXP_MAX = 709.0  # exp(x) for x above this overflows float64's range: returned as inf
EXP_MIN = -745.0  # ... and below this underflows to 0
POW2 = np.array([math.ldexp(1.0, k) for k in range(-1022, 1024)])  # 2**k, k = -1022..1023, exact


# Taylor coefficients, highest power first (Horner): e**r to r**14/14!, sin r / r and (1 - cos r) / r**2
# in powers of r**2 to r**18/19! and r**18/20!, and the atanh series (1/3, 1/5, ... 1/23) in s**2
EXP_COEFFS = tuple(1.0 / math.factorial(n) for n in range(14, 1, -1))
SIN_COEFFS = tuple((-1.0) ** n / math.factorial(2 * n + 1) for n in range(9, 0, -1))
COS_COEFFS = tuple((-1.0) ** (n + 1) / math.factorial(2 * n + 2) for n in range(9, 0, -1))
ATANH_COEFFS = tuple(1.0 / (2 * n + 1) for n in range(11, 0, -1))


@njit(cache=True)
def _horner(coeffs, x):
    """coeffs[0] x^(n-1) + ... + coeffs[n-1], evaluated in this one fixed order."""
    p = coeffs[0]
    for i in range(1, len(coeffs)):
        p = p * x + coeffs[i]
    return p


@njit(cache=True)
def _exp_reduced(r):
    """e**r for |r| <= ln2/2 (Taylor to r**14/14!: truncation below 1e-17 relative)."""
    return 1.0 + (r + r * r * _horner(EXP_COEFFS, r))


@njit(cache=True)
def exp(x):
    """e**x, the same bits on every CPU (about 1 ulp)."""
    if x != x:
        return x
    if x > EXP_MAX:
        return math.inf
    if x < EXP_MIN:
        return 0.0
    k = math.floor(x * INV_LN2 + 0.5)
    r = (x - k * LN2_HI) - k * LN2_LO
    p = _exp_reduced(r)  # in [0.70, 1.42]
    if k < -1021:  # a subnormal result: ldexp rounds it once
        return math.ldexp(p, int(k))
    return p * POW2[int(k) + 1022]  # exact, and half the time of ldexp's call


@njit(cache=True)
def _sin_reduced(r):
    """sin r for |r| <= pi/4 (Taylor to r**19/19!)."""
    r2 = r * r
    return r + r * r2 * _horner(SIN_COEFFS, r2)


@njit(cache=True)
def _cos_reduced(r):
    """cos r for |r| <= pi/4 (Taylor to r**20/20!): 1 - r2/2 + r2^2 p, the leading subtraction last
    so the small terms are not lost."""
    r2 = r * r
    return 1.0 - (0.5 * r2 - r2 * r2 * _horner(COS_COEFFS, r2))


@njit(cache=True)
def sincos(x):
    """(sin x, cos x), the same bits on every CPU (about 1-2 ulp for |x| < 1e6)."""
    k = math.floor(x * INV_PIO2 + 0.5)
    r = ((x - k * PIO2_1) - k * PIO2_2) - k * PIO2_3
    s, c = _sin_reduced(r), _cos_reduced(r)
    q = int(k) & 3
    if q == 0:
        return s, c
    if q == 1:
        return c, -s
    if q == 2:
        return -s, -c
    return -c, s


@njit(cache=True)
def tan(x):
    """tan x = sin x / cos x (about 2-3 ulp away from the poles)."""
    s, c = sincos(x)
    return s / c


@njit(cache=True)
def _log(w):
    """ln w for w > 0 (finite), about 1 ulp: w = m 2**e with m in [sqrt(1/2), sqrt(2)),
    ln m = 2 atanh(s), s = (m - 1) / (m + 1), |s| < 0.172 (series to s**23)."""
    m, e = math.frexp(w)  # m in [0.5, 1)
    if m < 0.7071067811865476:
        m *= 2.0
        e -= 1
    f = m - 1.0
    s = f / (2.0 + f)
    s2 = s * s
    p = _horner(ATANH_COEFFS, s2)
    # 2 atanh(s) = f - (hfsq - s (hfsq + R)), R = 2 s2 p, hfsq = f^2/2: f enters exactly, the
    # correction terms are small (fdlibm's arrangement of the same series)
    hfsq = 0.5 * f * f
    lnm = f - (hfsq - s * (hfsq + 2.0 * s2 * p))
    return e * LN2_HI + (lnm + e * LN2_LO)


@njit(cache=True)
def log1p(a):
    """ln(1 + a) for a > -1, accurate for small a too (Goldberg: ln(w) a / (w - 1), w = 1 + a)."""
    w = 1.0 + a
    if w == 1.0:
        return a
    return _log(w) * (a / (w - 1.0))


@njit(cache=True)
def softplus_sigmoid(u):
    """(ln(1 + e**u), 1 / (1 + e**-u)) without overflow, from the one exp both need, e**-|u|:
    softplus = max(u, 0) + ln(1 + e**-|u|), and the sigmoid e**u / (1 + e**u) written so that
    only e**-|u| appears."""
    e = exp(-abs(u))
    sp = max(u, 0.0) + log1p(e)
    if u >= 0.0:
        return sp, 1.0 / (1.0 + e)
    return sp, e / (1.0 + e)


# --- correctly rounded, elementwise, for a few thousand values ------------------------------
_DIGITS = 40  # far past float64's 17: the one final rounding is the only one that matters


def pow10(u) -> np.ndarray:
    """10**u elementwise (array of float64), correctly rounded: the same bits on every CPU."""
    u = np.asarray(u, dtype=np.float64)
    with localcontext() as ctx:
        ctx.prec = _DIGITS
        ln10 = Decimal(10).ln()
        out = [float((Decimal(float(v)) * ln10).exp()) for v in u.ravel()]
    return np.array(out, dtype=np.float64).reshape(u.shape)


def log10(x) -> np.ndarray:
    """log10(x) elementwise for x > 0 (array of float64), correctly rounded."""
    x = np.asarray(x, dtype=np.float64)
    if np.any(~(x > 0)):
        raise ValueError("log10 needs positive values")
    with localcontext() as ctx:
        ctx.prec = _DIGITS
        out = [float(Decimal(float(v)).log10()) for v in x.ravel()]
    return np.array(out, dtype=np.float64).reshape(x.shape)
