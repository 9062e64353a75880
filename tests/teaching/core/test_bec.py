"""BEC half-spaces, redundancy and size on a table worked by hand (tests/teaching/core/hand_bec_table.py)."""
from __future__ import annotations

import numpy as np
import pytest

from teaching.core import bec
from tests.teaching.core.hand_bec_table import OPTIONS, THETAS, hand_bec_table

DEG = np.pi / 180


def unit(*v):
    v = np.asarray(v, np.float64)
    return np.round(v / np.linalg.norm(v), bec.NORMAL_DECIMALS)


def rows(a):
    return sorted(map(tuple, np.round(a, 8)))


def test_each_theta_takes_its_cheapest_option():
    table = hand_bec_table()
    # E3 by hand: u1 = (1,.1) costs 3.3, 2.5, 9, 5.15 -> (2,5); u2 = (.1,1): 3.3, 5.2, .9, 2 -> (9,0);
    # u3 = (.6,1): 4.8, 6.2, 5.4, 4.5 -> (5,1.5); θ*: 6, 7, 9, 6.5 -> (3,3)
    np.testing.assert_array_equal(table.features[3], [(3, 3), (2, 5), (9, 0), (5, 1.5)])
    for m, options in enumerate(OPTIONS):
        costs = np.asarray(options, np.float64) @ -THETAS.T
        np.testing.assert_array_equal(costs.min(0), (table.features[m] * -THETAS).sum(1))


def test_half_spaces_by_hand_drop_theta_stars_own_and_duplicates():
    table = hand_bec_table()
    h = bec.environment_half_spaces(table)
    # signs of θ* are (-1, -1): u = -w, and w·(φ* - φ) ≥ 0 reads u·(φ - φ*) ≥ 0
    np.testing.assert_array_equal(bec.weight_signs(table.theta_star), [-1, -1])
    assert rows(h[0]) == rows([unit(-1, 2), unit(2, -1)])  # u3 takes θ*'s (3,3): no constraint
    assert rows(h[1]) == rows([unit(-1, 3), unit(3, -2)])  # u2, u3 share (6,1): one constraint
    assert rows(h[2]) == rows([unit(-2, 3)])
    assert rows(h[3]) == rows([unit(-1, 2), unit(2, -1), unit(0.8, -0.6)])  # (6,-3) scaled to (2,-1)


def test_redundant_half_spaces_are_removed_by_hand():
    h = bec.environment_half_spaces(hand_bec_table())
    # E3: (2,-1) allows up to atan 2 = 63.43°, (2,-1.5) only up to atan(4/3) = 53.13°: redundant
    assert rows(bec.remove_redundant(h[3])) == rows([unit(-1, 2), unit(0.8, -0.6)])
    assert rows(bec.remove_redundant(h[0])) == rows(h[0])  # both sides bound E0
    # all four: the tightest lower bound is E2's 33.69° (-2,3), the tightest upper E3's 53.13° (0.8,-0.6)
    union = bec.union(h)
    assert len(union) == 6  # (-1,2) and (2,-1) appear twice
    assert rows(bec.remove_redundant(union)) == rows([unit(-2, 3), unit(0.8, -0.6)])
    # a constraint implied by the sign constraints alone (u ≥ 0) is redundant too
    assert rows(bec.remove_redundant(np.vstack([union, unit(1, 1)]))) == rows([unit(-2, 3), unit(0.8, -0.6)])


def test_each_facets_cut_by_hand():
    # on the line u = (s, 1 - s) the hand table's rows bound s: unit(-2, 3) s ≤ 3/5, unit(-1, 2) s ≤ 2/3,
    # unit(-1, 3) s ≤ 3/4, unit(0.8, -0.6) s ≥ 3/7, unit(3, -2) s ≥ 2/5, unit(2, -1) s ≥ 1/3
    found = bec.facets(bec.union(bec.environment_half_spaces(hand_bec_table())))
    lo, hi = unit(-2, 3), unit(0.8, -0.6)
    assert rows(found.normals) == rows([lo, hi]) and found.uncertain == 0
    # without lo, s reaches 2/3, where lo·u = (3 - 5 * 2/3) / √13; without hi, s reaches 2/5: 1.4 * 2/5 - 0.6
    cut = dict(zip(map(tuple, found.normals), found.cuts, strict=True))
    assert cut[tuple(lo)] == pytest.approx(1 / (3 * np.sqrt(13)), rel=1e-9)
    assert cut[tuple(hi)] == pytest.approx(0.04, rel=1e-9)
    assert found.inradius == pytest.approx(bec.interior_point(found.normals)[1], rel=1e-9)
    assert found.thinnest() == pytest.approx(0.04 / found.inradius, rel=1e-9)


@pytest.mark.parametrize("cut, replaces", [(1e-6, True), (3e-9, True), (1e-11, False)])
def test_a_row_a_hair_inside_another_is_a_facet_when_it_cuts_more_than_the_tolerance(cut, replaces):
    # unit(1 - s0, -s0) bounds s ≥ s0, and cuts the hand region (s ≥ 3/7) by (s0 - 3/7) / |(1 - s0, -s0)|
    s0 = 3 / 7 + cut * np.hypot(4 / 7, 3 / 7)
    tighter = unit(1 - s0, -s0)
    union = np.vstack([bec.union(bec.environment_half_spaces(hand_bec_table())), tighter])
    found = bec.facets(union)
    tol = bec.cut_tolerance(found.inradius)
    assert 1e-11 < tol < 3e-9  # the cases straddle it: 1e-8 of this region's inradius
    lo, hi = unit(-2, 3), unit(0.8, -0.6)
    assert not any(np.array_equal(r, tighter) for r in (lo, hi))  # three rows, not merged by the rounding
    # the lower bound is never lost: the tighter row when its cut counts, else one of the two
    assert len(found.normals) == 2 and any(np.array_equal(r, lo) for r in found.normals)
    lower = [r for r in found.normals if not np.array_equal(r, lo)]
    if replaces:
        assert rows(lower) == rows([tighter]) and found.cuts.min() == pytest.approx(min(cut, 0.04), rel=1e-3)
    else:
        assert rows(lower) in (rows([tighter]), rows([hi]))


@pytest.mark.parametrize("env, lo, hi", [
    (0, np.arctan(1 / 2), np.arctan(2)),       # (63.43 - 26.57) / 90 = 0.4097
    (1, np.arctan(1 / 3), np.arctan(3 / 2)),   # (56.31 - 18.43) / 90 = 0.4209
    (2, np.arctan(2 / 3), np.pi / 2),          # (90 - 33.69) / 90 = 0.6257
    (3, np.arctan(1 / 2), np.arctan(4 / 3)),   # (53.13 - 26.57) / 90 = 0.2952
])
def test_bec_size_in_two_features_is_the_angle_over_a_right_angle(env, lo, hi):
    h = bec.environment_half_spaces(hand_bec_table())[env]
    size, error = bec.bec_size(h)
    assert size == pytest.approx((hi - lo) / (np.pi / 2), abs=1e-8) and error == 0.0


def test_bec_size_of_the_whole_and_the_monte_carlo_estimate_agree_with_the_angle():
    union = bec.union(bec.environment_half_spaces(hand_bec_table()))
    exact = (np.arctan(4 / 3) - np.arctan(2 / 3)) / (np.pi / 2)  # (53.13 - 33.69) / 90 = 0.2160
    assert bec.bec_size(union)[0] == pytest.approx(exact, abs=1e-8)
    # the sampled fraction of the quarter circle (what bec_size does above 2 features) agrees
    samples = bec.sphere_samples(2, 20_000, seed=1)
    inside = (samples @ union.T >= 0).all(1).mean()
    assert abs(inside - exact) < 4 * np.sqrt(exact * (1 - exact) / 20_000)


def test_monte_carlo_size_is_seeded_and_reports_its_error():
    normals = np.array([unit(-1, 1, 0), unit(0, -1, 1)])  # 3 features: u0 ≤ u1 ≤ u2, one sixth by symmetry
    size, error = bec.bec_size(normals)
    assert (size, error) == bec.bec_size(normals)
    assert error == pytest.approx(np.sqrt(size * (1 - size) / bec.MC_SAMPLES))
    assert abs(size - 1 / 6) < 4 * error


def test_implication_by_linear_programming():
    h = bec.environment_half_spaces(hand_bec_table())
    assert bec.implies(np.vstack([h[2], h[3]]), np.vstack(h))  # E2 and E3 hold the whole's BEC
    assert not bec.implies(np.vstack([h[0], h[1]]), np.vstack(h))


def test_a_theta_star_with_a_zero_weight_has_no_sign_constrained_space():
    with pytest.raises(bec.BECError, match="zero weight"):
        bec.weight_signs([-1.0, 0.0])


def _random_region(d: int, k: int, seed: int) -> np.ndarray:
    """(k, d) unit normals of constraints that all hold at one point of the orthant (a region with
    an interior), many of them redundant: normals a - (a·p) p / |p|² + small positive slack."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(0.2, 1.0, d)
    a = rng.standard_normal((k, d))
    a -= np.outer(a @ p, p) / (p @ p)  # through p ...
    a += rng.uniform(0.0, 0.3, (k, 1)) * p / np.linalg.norm(p)  # ... then p strictly inside
    return bec.unit_normals(a)


@pytest.mark.parametrize("d, k, seed", [(3, 120, 0), (5, 200, 2)])
def test_redundancy_removal_equals_one_linear_program_per_constraint(d, k, seed):
    # the definition, independent of the vertex method: a row is redundant when the others imply it
    normals = _random_region(d, k, seed)
    brute = [i for i in range(len(normals)) if not bec.is_implied(np.delete(normals, i, 0), normals[i])]
    assert 3 <= len(brute) < len(normals) / 4
    np.testing.assert_array_equal(bec.remove_redundant(normals), normals[brute])


@pytest.mark.parametrize("generate", [1, 7, bec.GENERATE])
def test_the_interior_point_is_the_deepest_of_all_the_constraints(monkeypatch, generate):
    # a few rows per round forces many rounds of constraint generation; the depth must be the one
    # linear program over every row gives
    normals = _random_region(4, 500, 3)
    monkeypatch.setattr(bec, "GENERATE", generate)
    u, r = bec.interior_point(normals)
    _, whole = bec._deepest(normals, 4)
    assert r == pytest.approx(whole, abs=1e-9) and r > 0
    assert (normals @ u >= r - 1e-9).all() and (u >= r - 1e-9).all() and u.sum() == pytest.approx(1.0)


def test_the_interior_point_of_two_features_by_hand():
    # the whole's BEC of the hand table is the arc 33.69°..53.13° of the quarter circle; on the line
    # u0 + u1 = 1 its deepest point is equally far (in n·u) from the two bounding constraints
    union = bec.union(bec.environment_half_spaces(hand_bec_table()))
    u, r = bec.interior_point(union)
    lo, hi = unit(-2, 3), unit(0.8, -0.6)
    assert lo @ u == pytest.approx(r, abs=1e-9) and hi @ u == pytest.approx(r, abs=1e-9)
    grid = np.linspace(0, 1, 200_001)[:, None] * [1.0, -1.0] + [0.0, 1.0]  # (s, 1 - s)
    depth = np.minimum((grid @ union.T).min(1), grid.min(1))
    assert r == pytest.approx(depth.max(), abs=1e-5)
