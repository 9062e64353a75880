"""teaching.core.detmath against references computed in decimal arithmetic at 60 digits.

The references share nothing with the code under test: no float range reduction, no split
constants, no truncated series (each series here runs until its terms vanish at 60 digits), so an
error in a constant or a missing term shows as a gap of many ulps.
"""
from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np
import pytest

from teaching.core import detmath
from teaching.core.candidates import sample_thetas
from teaching.domains.driving.features import reward
from teaching.domains.driving.planner import _pool_best  # the planner's private helper: it must agree with reward
from teaching.domains.driving.world import THETA_STAR

# pi to 100 digits: the reference's own range reduction uses it, nothing of detmath's
PI = Decimal("3.14159265358979323846264338327950288419716939937510582097494459230781640628620899862803482534211706798")
PREC = 60


def _series(r: Decimal, start: Decimal, first: int) -> Decimal:
    """sum of (-1)^n r^(2n+first) / (2n+first)! until the terms are below 1e-70."""
    total, term, n = Decimal(0), start, first
    while abs(term) > Decimal(10) ** -70:
        total += term
        term = -term * r * r / ((n + 1) * (n + 2))
        n += 2
    return total


def ref_sincos(x: float) -> tuple[Decimal, Decimal]:
    with localcontext() as ctx:
        ctx.prec = PREC
        x = Decimal(x)
        k = int((x / (PI / 2)).to_integral_value())
        r = x - k * PI / 2
        s, c = _series(r, r, 1), _series(r, Decimal(1), 0)
        return [(s, c), (c, -s), (-s, -c), (-c, s)][k % 4]


def ref(fn, *args) -> Decimal:
    with localcontext() as ctx:
        ctx.prec = PREC
        return fn(*(Decimal(float(a)) for a in args))


def ulps(got: float, want: Decimal) -> float:
    want = float(want)
    return abs(got - want) / math.ulp(want) if want else abs(got)


RNG = np.random.default_rng(2026)


def test_the_split_constants_add_up_to_pi_over_2_and_ln2():
    with localcontext() as ctx:
        ctx.prec = PREC
        pio2 = Decimal(detmath.PIO2_1) + Decimal(detmath.PIO2_2) + Decimal(detmath.PIO2_3)
        assert abs(pio2 - PI / 2) < Decimal(10) ** -36
        ln2 = Decimal(detmath.LN2_HI) + Decimal(detmath.LN2_LO)
        assert abs(ln2 - Decimal(2).ln()) < Decimal(10) ** -25
    # the high parts have their low bits clear, so k * PART is exact for the k the functions use
    for part, bits in ((detmath.PIO2_1, 33), (detmath.PIO2_2, 33), (detmath.LN2_HI, 32)):
        mantissa = int(math.frexp(part)[0] * 2 ** 53)
        assert mantissa % 2 ** (53 - bits) == 0


def worst_ulps(fn, points) -> float:
    """The largest error in ulps of fn over points, fn(x) -> (got, want)."""
    return max(ulps(*fn(float(x))) for x in points)


def test_exp_within_an_ulp():
    points = [0.0, 1e-300, -1e-20, 1.0, -1.0, 0.5 * math.log(2), 700.0, -700.0, -708.5, -744.0,
              *RNG.uniform(-40, 40, 2000), *RNG.uniform(-1e-3, 1e-3, 200)]
    assert worst_ulps(lambda x: (detmath.exp(x), ref(lambda d: d.exp(), x)), points) <= 1.0


def test_exp_at_the_ends_of_the_range():
    assert detmath.exp(710.0) == math.inf
    assert detmath.exp(-746.0) == 0.0
    assert math.isnan(detmath.exp(math.nan))


def test_sin_cos_within_an_ulp_and_tan_within_three():
    """Headings near pi/2 (the car drives up the road), steering angles near 0, and a wide sweep."""
    points = [0.0, math.pi / 4, math.pi / 2, -math.pi / 2, math.pi, 3.0, 100.0,
              *RNG.uniform(1.2, 1.95, 1000), *RNG.uniform(-0.6, 0.6, 500), *RNG.uniform(-50, 50, 1000)]
    worst = {"sin": 0.0, "cos": 0.0, "tan": 0.0}
    for x in map(float, points):
        s, c = ref_sincos(x)
        got_s, got_c = detmath.sincos(x)
        worst["sin"] = max(worst["sin"], ulps(got_s, s))
        worst["cos"] = max(worst["cos"], ulps(got_c, c))
        if abs(float(c)) > 1e-3:
            with localcontext() as ctx:
                ctx.prec = PREC
                worst["tan"] = max(worst["tan"], ulps(detmath.tan(x), s / c))
    assert worst["sin"] <= 1.0 and worst["cos"] <= 1.0 and worst["tan"] <= 3.0, worst


def test_softplus_and_sigmoid_within_two_ulps():
    points = [0.0, 1e-12, -1e-12, 40.0, -40.0, *RNG.uniform(-45, 45, 2000)]
    assert worst_ulps(lambda u: (detmath.softplus_sigmoid(u)[0], ref(lambda d: (1 + d.exp()).ln(), u)),
                      points) <= 2.0
    assert worst_ulps(lambda u: (detmath.softplus_sigmoid(u)[1], ref(lambda d: 1 / (1 + (-d).exp()), u)),
                      points) <= 2.0


def test_log1p_within_two_ulps():
    points = [1e-300, 1e-17, 1e-9, 0.5, 1.0, 3.0, -0.5, -0.999, *10 ** RNG.uniform(-15, 1, 2000)]
    assert worst_ulps(lambda a: (detmath.log1p(a), ref(lambda d: (1 + d).ln(), a)), points) <= 2.0


def test_pow10_and_log10_are_correctly_rounded():
    u = RNG.uniform(-1, 1, 500)
    got = detmath.pow10(u)
    with localcontext() as ctx:
        ctx.prec = PREC
        ln10 = Decimal(10).ln()
        want = [float((Decimal(float(v)) * ln10).exp()) for v in u]
    assert got.tolist() == want  # the nearest double to the exact value, not merely close
    x = 10 ** RNG.uniform(-3, 3, 200)
    assert detmath.log10(x).tolist() == [float(ref(lambda d: d.log10(), v)) for v in x]
    assert detmath.pow10(np.zeros((2, 3))).shape == (2, 3)
    with pytest.raises(ValueError, match="positive"):
        detmath.log10([1.0, 0.0])


def test_candidate_thetas_are_theta_star_times_exact_powers_of_ten():
    """The sampled thetas are -|theta*| 10**u with 10**u correctly rounded: recomputed here from the
    same seeded draws with decimal arithmetic of our own."""
    thetas = sample_thetas(50, seed=7, theta_star=THETA_STAR)
    u = np.random.default_rng(7).uniform(-1.0, 1.0, size=(49, 5))
    star = np.abs(thetas[0])
    with localcontext() as ctx:
        ctx.prec = PREC
        scale = np.array([[float(Decimal(10) ** Decimal(float(v))) for v in row] for row in u])
    assert np.array_equal(thetas[1:], -star * scale)


def test_the_reward_sums_left_to_right():
    """features.reward (and the planner's pool rewards, which must agree with it to the bit) sum
    theta_i phi_i from i = 0 up, each product rounded, whatever the CPU's BLAS would do; the planner's
    best pool trajectory is the first argmax of those sums over the allowed ones."""
    phi = RNG.normal(size=(40, 5))
    phi[7], phi[31] = phi[3], phi[12]  # ties: the lower index wins
    thetas = -np.abs(RNG.normal(size=(30, 5)))
    by_hand = np.array([[float(sum((float(t[i] * p[i]) for i in range(5)), start=0.0)) for p in phi]
                        for t in thetas])
    assert np.array_equal(reward(phi[None, :, :], thetas[:, None, :]), by_hand)
    allowed = RNG.random(40) < 0.7
    own = RNG.integers(0, 40, size=30)
    best, best_r, own_r = _pool_best(phi, thetas, allowed, own)
    masked = np.where(allowed, by_hand, -np.inf)
    assert np.array_equal(best, masked.argmax(axis=1))
    assert np.array_equal(best_r, masked.max(axis=1))
    assert np.array_equal(own_r, masked[np.arange(30), own])
    assert np.array_equal(_pool_best(phi, thetas)[0], by_hand.argmax(axis=1))
    none = _pool_best(phi, thetas, np.zeros(40, bool))
    assert np.array_equal(none[0], np.zeros(30)) and np.all(none[1] == -np.inf)
