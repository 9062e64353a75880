"""Behavioural equivalence classes (BEC): the weights under which θ*'s trajectories stay optimal.

Longer than 400 lines because a BEC's exact region (its half-spaces, redundant ones removed by linear
programs) and its size (a share of the sphere, sampled) share the private geometry below; split, each
half would import the other's helpers.

Brown & Niekum (2019): a demonstration ξ* in environment E holds the reward weights w for which
w·(φ(ξ*) − φ(ξ)) ≥ 0 for every other trajectory ξ of E.  Here the other trajectories are the
table's: the optimal trajectory of every candidate θ in E, a finite stand-in for "all
trajectories" (so a BEC here contains the true one).  The BEC of a set of environments is the
intersection of theirs.

Weights live in the domain's sign-constrained space, the orthant of θ* (every weight ≤ 0 in
both domains: weights are costs).  Internally everything is in the positive orthant
u = s ⊙ w ≥ 0 with s = sign(θ*) (D,), where a half-space w·a ≥ 0 reads u·(s ⊙ a) ≥ 0; the
normals this module returns are in u-space, scaled to unit length and rounded to
NORMAL_DECIMALS decimals, so that two constraints equal up to positive scaling are equal arrays.

Non-redundant constraints come from linear programs (SciPy's HiGHS) over the slice
{u ≥ 0, Σu = 1} of the cone, which holds every direction of the orthant once.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import HalfspaceIntersection, QhullError

# Unit normals equal to this many decimals are one constraint (same half-space up to scaling).  The
# rounding moves normal·u by at most 5e-13 on the simplex, below every cut of the shipped tables (the
# thinnest, 1.4e-10, is the tiny table's); at 9 decimals it moved it by 5e-10, which made and unmade cuts
# of that size.
NORMAL_DECIMALS = 12
# A feature difference shorter than this is θ*'s own trajectory: no constraint.
ZERO_NORM = 1e-12
# What counts as a cut.  A constraint cuts the region (is a facet, not redundant) when its minimum of
# normal·u over the region of the others (u on the simplex Σu = 1, found on that region's vertices) is below
# -cut_tolerance(r): CUT_REL of the region's inradius r (interior_point's depth), and never less than
# CUT_FLOOR, the vertices' own resolution (on the shipped tables every constraint either cuts by 1e-10 or
# more or touches the region within 1e-13).  One absolute 1e-8 dropped facets of the tiny table cutting 4e-9,
# 1.4e-10 and 3e-10 (down to 3e-7 of its inradius), and SCOT's cover then missed them.
CUT_REL, CUT_FLOOR = 1e-8, 1e-12
# An LP minimum at or above -LP_TOL counts as ≥ 0 where an LP decides (is_implied; a region without
# interior): HiGHS answers these LPs within about 1e-9 (it called a facet that cuts 1.4e-10 redundant by
# 3.7e-10), so facets are decided on the region's vertices instead, where it has an interior.
LP_TOL = 1e-8
# HiGHS's default feasibility tolerances (1e-7) let an LP's optimum violate constraints by more
# than LP_TOL, which moved the minima by 8e-8 on the 5-feature tiny table: tightened below it.
HIGHS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
# Monte-Carlo BEC size above 2 features: samples on the orthant's unit sphere, and their seed.
MC_SAMPLES, MC_SEED = 100_000, 0
PILOT = 1000  # samples that order the constraints of a Monte-Carlo size (speed only)
CHUNK = 1 << 22  # (sample, constraint) products held at once when testing every constraint together
# The interior point's constraint generation: rows added per round, and the shortfall below the
# working set's depth that counts as a violation.
GENERATE, GENERATE_TOL = 1000, 1e-12


class BECError(ValueError):
    """A table whose BECs cannot be formed (one-line message)."""


def weight_signs(theta_star) -> np.ndarray:
    """(D,) ±1: the sign of each weight in the domain's space, θ*'s.  BECError if θ* has a 0."""
    s = np.sign(np.asarray(theta_star, np.float64))
    if not len(s) or (s == 0).any():
        raise BECError(f"θ* {np.asarray(theta_star).tolist()} has a zero weight: "
                       "its sign-constrained space is undefined")
    return s


def unit_normals(a: np.ndarray) -> np.ndarray:
    """(K, D) -> (K', D): rows scaled to unit length and rounded to NORMAL_DECIMALS, rows shorter
    than ZERO_NORM dropped, duplicates dropped; sorted lexicographically (np.unique)."""
    a = np.asarray(a, np.float64).reshape(-1, np.shape(a)[-1])
    norm = np.linalg.norm(a, axis=1)
    keep = norm > ZERO_NORM
    # + 0.0 turns -0.0 into 0.0: equal normals are then equal bytes too (summaries.cover_matrix)
    return np.unique(np.round(a[keep] / norm[keep, None], NORMAL_DECIMALS) + 0.0, axis=0)


def union(normals: list[np.ndarray]) -> np.ndarray:
    """(K, D): the distinct rows of several sets of :func:`unit_normals` (the BEC of their
    environments together), sorted.  Rows are compared as they are: normalising again would move
    their last rounded digit, and a constraint would no longer match its environment's."""
    normals = [np.asarray(n, np.float64) for n in normals]
    return np.unique(np.vstack(normals), axis=0) if normals else np.zeros((0, 0))


def half_spaces(features: np.ndarray, signs: np.ndarray, star: int = 0) -> np.ndarray:
    """The BEC of one environment as (K, D) unit normals in u-space (u·normal ≥ 0).

    features: (N, D) φ of each candidate θ's trajectory in the environment (row ``star`` is θ*'s),
    in the table's normalised feature units.  signs: (D,) from :func:`weight_signs`.
    """
    f = np.asarray(features, np.float64)
    return unit_normals((f[star] - f) * signs)


def environment_half_spaces(table) -> list[np.ndarray]:
    """(M,) list of each environment's BEC normals (K_m, D) (:func:`half_spaces`, θ* = theta 0)."""
    signs = weight_signs(table.theta_star)
    return [half_spaces(table.features[m], signs, table.theta_star_index) for m in range(table.n_envs)]


def lp_minimum(normals: np.ndarray, c: np.ndarray) -> float:
    """min c·u over {u ≥ 0, Σu = 1, normals·u ≥ 0} (normals (K, D), c (D,)); +inf if empty."""
    d = len(c)
    res = linprog(c, A_ub=-normals if len(normals) else None, b_ub=np.zeros(len(normals)) if len(normals) else None,
                  A_eq=np.ones((1, d)), b_eq=[1.0], bounds=[(0, None)] * d, method="highs", options=HIGHS)
    return float(res.fun) if res.status == 0 else np.inf


def cut_tolerance(inradius: float) -> float:
    """The smallest cut counted in a region of inradius ``inradius`` (simplex units): CUT_REL of it,
    at least CUT_FLOOR."""
    return max(CUT_FLOOR, CUT_REL * max(float(inradius), 0.0))


def is_implied(normals: np.ndarray, c: np.ndarray, tol: float = LP_TOL) -> bool:
    """Whether every u of the region ``normals`` (K, D) satisfies c·u ≥ -tol (c (D,)): c is
    redundant given them, to ``tol`` (default LP_TOL: as far as the LP can tell)."""
    return lp_minimum(np.asarray(normals, np.float64).reshape(-1, len(c)), np.asarray(c, np.float64)) >= -tol


def interior_point(normals: np.ndarray) -> tuple[np.ndarray, float]:
    """(u (D,), r): the point of {u ≥ 0, Σu = 1, normals·u ≥ 0} deepest inside every constraint
    (unit normals: u·n ≥ r and u_i ≥ r for all), r ≤ 0 when the region has no interior.

    By constraint generation: the LP over a working set of constraints, then every constraint
    checked at its optimum, the most violated added, until none is.  A relaxation's optimum that
    every constraint holds is the whole LP's, and a whole table's union has millions of rows, of
    which a few dozen bind.
    """
    normals = np.asarray(normals, np.float64)
    d = normals.shape[1]
    centre = np.full(d, 1.0 / d)
    work = _most_violated(normals @ centre, np.inf, GENERATE)
    while True:
        u, r = _deepest(normals[work], d)
        if not np.isfinite(r):
            return centre, -np.inf
        at = normals @ u
        outside = at.copy()
        outside[work] = np.inf  # the working set's rows hold to HiGHS's tolerance: only new rows can join
        extra = _most_violated(outside, r - GENERATE_TOL, GENERATE)
        if not len(extra):
            return u, min(r, float(at.min(initial=np.inf)))
        work = np.union1d(work, extra)


def _most_violated(at: np.ndarray, below: float, k: int) -> np.ndarray:
    """Indices of the (at most) k smallest entries of ``at`` (K,) that are below ``below``, sorted."""
    below_idx = np.flatnonzero(at < below)
    if len(below_idx) > k:
        below_idx = below_idx[np.argpartition(at[below_idx], k)[:k]]
    return np.sort(below_idx)


def _deepest(normals: np.ndarray, d: int) -> tuple[np.ndarray, float]:
    """:func:`interior_point`'s LP over the rows ``normals`` (K, D) as given: (u, r), r = -inf if
    HiGHS finds no optimum."""
    k = len(normals)
    a_ub = np.vstack([np.hstack([-normals, np.ones((k, 1))]), np.hstack([-np.eye(d), np.ones((d, 1))])])
    res = linprog(np.r_[np.zeros(d), -1.0], A_ub=a_ub, b_ub=np.zeros(k + d), A_eq=np.r_[np.ones(d), 0.0][None],
                  b_eq=[1.0], bounds=[(0, None)] * d + [(None, 1.0)], method="highs", options=HIGHS)
    if res.status != 0:
        return np.full(d, 1.0 / d), -np.inf
    return res.x[:d], float(-res.fun)


def _vertices(normals: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """(V, D) vertices of {u ≥ 0, Σu = 1, normals·u ≥ 0}, given a point strictly inside it.
    Works on y = u[:-1] (u[-1] = 1 − Σy), a (D−1)-dimensional polytope."""
    d = normals.shape[1]
    a = np.vstack([normals, np.eye(d)])  # u ≥ 0 as rows e_i·u ≥ 0
    # a·u = (a[:-1] − a[-1])·y + a[-1] ≥ 0  ->  qhull's form  A y + b ≤ 0
    rows = np.hstack([-(a[:, :-1] - a[:, -1:]), -a[:, -1:]])
    if d == 2:
        c, b = rows[:, 0], rows[:, 1]  # c y + b ≤ 0 bounds y from below (c < 0) or above (c > 0)
        with np.errstate(divide="ignore"):
            bound = -b / c
        y = np.array([[max(bound[c < 0], default=0.0)], [min(bound[c > 0], default=1.0)]])
    else:
        y = HalfspaceIntersection(rows, inside[:-1]).intersections
    return np.hstack([y, 1.0 - y.sum(1, keepdims=True)])


@dataclass(frozen=True)
class Facets:
    """The non-redundant constraints of a region and how sure each is (:func:`facets`).

    normals (F, D): the facets, in the input's order.  cuts (F,): how far each cuts into the region of
    every other row (minus its minimum there, on that region's vertices; simplex units; with no interior,
    the LP's against the other facets).  inradius: the region's (interior_point's depth).  uncertain: how
    many facets no witness point certifies in float64: kept, so that a cover holds them too."""

    normals: np.ndarray
    cuts: np.ndarray
    inradius: float
    uncertain: int = 0

    def thinnest(self) -> float:
        """The smallest cut as a fraction of the inradius (inf without facets or interior)."""
        return float(self.cuts.min() / self.inradius) if len(self.cuts) and self.inradius > 0 else np.inf


def remove_redundant(normals: np.ndarray) -> np.ndarray:
    """The non-redundant rows of ``normals`` (K, D) (:func:`facets`'s normals)."""
    return facets(normals).normals


def facets(normals: np.ndarray) -> Facets:
    """The non-redundant rows of ``normals`` (K, D) (unit, deduplicated: :func:`unit_normals`): the
    smallest subset with the same region inside the orthant, in the input's order, each row that cuts
    the region by more than :func:`cut_tolerance` of its inradius.

    Clarkson's method: keep a set R of proven facets; the region of R has vertices (qhull), and a
    constraint no vertex violates is redundant; a violated one gives a ray from an interior point
    to the vertex, and the first constraint the ray crosses is a facet of the whole, added to R.
    Costs one vertex enumeration per facet, not one LP per constraint.  A region without interior
    (θ* indifferent between two trajectories), or one qhull cannot take, falls back to one LP per
    constraint against the others.  Each facet is then confirmed on the vertices of the other facets'
    region, its cut measured against every other row (:func:`_cut`) and certified by a witness
    (:func:`_certified`); a warning names any it cannot certify.
    """
    normals = np.asarray(normals, np.float64)
    if not len(normals):
        return Facets(normals, np.zeros(0), 0.0)
    inside, depth = interior_point(normals)
    tol = cut_tolerance(depth)
    if depth > tol:
        try:
            return _facets_by_vertices(normals, inside, depth, tol)
        except QhullError:
            pass
    return _facets_by_lp(normals, max(depth, 0.0))


def _facets_by_vertices(normals: np.ndarray, inside: np.ndarray, depth: float, tol: float) -> Facets:
    cuts, witnesses = {}, {}
    kept = _clarkson(normals, inside, tol)
    for i in list(kept):  # one at a time: of two rows within tol of each other, one stays
        others = [j for j in kept if j != i]
        among_facets, low, witnesses[i] = _cut(normals, i, others, inside)
        if among_facets >= -tol:
            kept = others
        else:
            cuts[i] = -low
    kept = sorted(kept)
    uncertain = sum(not _certified(normals, i, witnesses[i], inside, depth) for i in kept)
    if uncertain:
        logging.getLogger(__name__).warning(
            "%d of the region's %d facets cut it by less than float64 can certify (thinnest cut %.2g of the "
            "inradius %.2g): kept as facets, so a cover holds them too", uncertain, len(kept),
            min(cuts.values()) / depth, depth)
    return Facets(normals[kept], np.array([cuts[i] for i in kept]), depth, uncertain)


def _facets_by_lp(normals: np.ndarray, depth: float) -> Facets:
    """A region without interior, or one qhull cannot take: one LP per row against the others kept (the
    LP's answers, to LP_TOL)."""
    kept, cuts = list(range(len(normals))), {}
    for i in list(kept):
        others = [j for j in kept if j != i]
        low = lp_minimum(normals[others], normals[i])
        if low >= -LP_TOL:
            kept = others
        else:
            cuts[i] = -low
    return Facets(normals[kept], np.array([cuts[i] for i in kept]), depth)


def _cut(normals: np.ndarray, i: int, start: list[int], inside: np.ndarray) -> tuple[float, float, np.ndarray]:
    """(min over the rows ``start``, min over every row but i, u): row i's minimum over the region of the
    rows ``start`` of ``normals`` (K, D), then over that of every other row, and a vertex where the latter
    lies.  The minimum over the vertices (qhull) of the region of the rows ``start``, rows violated at the
    minimising vertex added until none is (a row Clarkson never needed may lie a hair behind row i): a
    vertex is exact to float64's rounding, where HiGHS answers within its tolerance (on the tiny table it
    called a facet cutting 1.4e-10 redundant by 3.7e-10).  ``inside`` (D,): strictly inside every row."""
    work = np.asarray(start, np.int64)
    first = None
    while True:
        low, u = _region_min(normals[work], normals[i], inside)
        first = low if first is None else first
        values = normals @ u
        values[i] = np.inf
        values[work] = np.inf
        extra = _most_violated(values, -GENERATE_TOL, GENERATE)
        if not len(extra):
            return first, low, u
        work = np.union1d(work, extra)


def _region_min(rows: np.ndarray, c: np.ndarray, inside: np.ndarray) -> tuple[float, np.ndarray]:
    """(min c·u over the region of ``rows`` (K, D), a vertex where it lies): on the region's vertices."""
    vertices = _vertices(rows, inside)
    at = vertices @ c
    k = int(np.argmin(at))
    return float(at[k]), vertices[k]


def _certified(normals: np.ndarray, i: int, u: np.ndarray, inside: np.ndarray, depth: float) -> bool:
    """Whether a point is shown, in float64 and against every row of ``normals`` (K, D) but i, to lie in
    their region and outside row i: the vertex ``u`` (D,) where row i's minimum lies (:func:`_cut`), moved
    towards ``inside`` (depth > 0 inside every row) just far enough to undo any violation its rounding left."""
    others = np.delete(normals, i, 0)
    violation = max(0.0, -float((others @ u).min(initial=np.inf)), -float(u.min()))
    t = min(1.0, (2 * violation + 1e-15) / (violation + depth))
    point = (1 - t) * u + t * inside
    return bool((others @ point).min(initial=np.inf) >= 0 and point.min() >= 0 and normals[i] @ point < 0)


def _clarkson(normals: np.ndarray, inside: np.ndarray, tol: float) -> list[int]:
    facets: list[int] = []
    # The rows not yet shown redundant.  A row no vertex of the facets' region violates holds on
    # all of it, and that region only shrinks as facets join: the row is redundant for good, and
    # never the first crossed (its crossing lies at or beyond the target vertex).  Dropping such
    # rows leaves each pass over a whole table's millions of rows to the few still in question.
    ids = np.arange(len(normals))
    rows, at_inside = normals, normals @ inside  # at_inside > 0: strictly inside every constraint
    while True:
        v = _vertices(normals[facets], inside)
        worst = (rows @ v.T).min(1)
        violated = np.flatnonzero(worst < -tol)
        if not len(violated):
            return facets
        target = v[int(np.argmin(rows[violated[0]] @ v.T))]
        keep = worst < 0
        keep[np.isin(ids, facets)] = False
        ids, rows, at_inside = ids[keep], rows[keep], at_inside[keep]
        along = rows @ (target - inside)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(along < 0, at_inside / -along, np.inf)
        facets.append(int(ids[np.argmin(t)]))  # the first crossed: lowest index on exact ties


def implies(normals: np.ndarray, others: np.ndarray) -> bool:
    """Whether the region of ``normals`` (K, D) lies inside that of ``others`` (K', D): every
    constraint of ``others`` is implied (one LP each)."""
    return all(is_implied(normals, c) for c in np.asarray(others, np.float64))


def sphere_samples(d: int, n: int = MC_SAMPLES, seed: int = MC_SEED) -> np.ndarray:
    """(n, d) float64 uniform on the unit sphere's positive orthant (|N(0, I)| normalised), seeded."""
    g = np.abs(np.random.default_rng(seed).standard_normal((n, d)))
    return g / np.linalg.norm(g, axis=1, keepdims=True)


def bec_size(normals: np.ndarray, samples: np.ndarray | None = None) -> tuple[float, float]:
    """(size, standard error): the fraction of the orthant's unit sphere inside the region
    ``normals`` (K, D), a number in [0, 1].

    D = 2: exact, the region's angle over the quarter circle's π/2 (standard error 0).
    D > 2: the fraction of ``samples`` (S, D) (default :func:`sphere_samples`: MC_SAMPLES with
    seed MC_SEED) inside, standard error sqrt(p(1 − p)/S).  Passing the same samples for every
    region (common random numbers) makes their sizes comparable beyond that error.
    """
    normals = np.asarray(normals, np.float64)
    d = normals.shape[1]
    if d == 2:
        return _arc_fraction(normals), 0.0
    if samples is None:
        samples = sphere_samples(d)
    # The count is the samples every constraint keeps, in any order.  For speed, first the few
    # constraints that between them reject all of a pilot's samples they can (chosen greedily, each
    # rejecting most of what the earlier ones kept: environments have hundreds of near-parallel
    # constraints, so ordering them one by one would keep many passes over many samples), one pass
    # each over the survivors; then every constraint at once on the few samples left.
    alive = samples
    for n in normals[_pilot_cover(samples[:PILOT] @ normals.T < 0)]:
        alive = alive[alive @ n >= 0]
    inside = _count_inside(alive, normals)
    p = inside / len(samples)
    return p, float(np.sqrt(p * (1 - p) / len(samples)))


def bec_sizes(normals: list[np.ndarray], samples: int = MC_SAMPLES) -> np.ndarray:
    """(E,) BEC size of each environment's half-spaces (:func:`teaching.core.bec_size`), every
    one measured on the same seeded samples above 2 features, so their order is not sampling noise
    between environments (common random numbers)."""
    d = next((len(n[0]) for n in normals if len(n)), 2)
    points = sphere_samples(d, samples) if d > 2 else None
    return np.array([bec_size(n, points)[0] if len(n) else 1.0 for n in normals])


def environment_sizes(table, rows, samples: int = MC_SAMPLES) -> np.ndarray:
    """(E,) the BEC size of each of the table rows ``rows`` (E,) alone (:func:`bec_sizes`, θ* =
    the table's): an environment's size does not depend on which others are measured with it."""
    signs = weight_signs(table.theta_star)
    return bec_sizes([half_spaces(table.features[m], signs, table.theta_star_index) for m in rows], samples)


def _pilot_cover(rejects: np.ndarray) -> list[int]:
    """Columns of ``rejects`` (P, K) bool (pilot sample p violates constraint k) chosen greedily, each
    the one rejecting most of the samples no earlier one rejected (lowest index on ties), until no
    column rejects any of those left."""
    left = np.ones(len(rejects), bool)
    chosen: list[int] = []
    while left.any():
        counts = rejects[left].sum(0)
        best = int(np.argmax(counts))
        if counts[best] == 0:
            break
        chosen.append(best)
        left &= ~rejects[:, best]
    return chosen


def _count_inside(points: np.ndarray, normals: np.ndarray) -> int:
    """How many of ``points`` (S, D) lie on the inner side (n·x ≥ 0) of every row of ``normals``
    (K, D), in chunks of CHUNK products."""
    step = max(1, CHUNK // max(len(normals), 1))
    return sum(int(np.count_nonzero((points[i:i + step] @ normals.T >= 0).all(1)))
               for i in range(0, len(points), step))


def _arc_fraction(normals: np.ndarray) -> float:
    """2 features: the angles of u = (cos a, sin a), a ∈ [0, π/2], with normals·u ≥ 0, over π/2."""
    lo, hi = 0.0, np.pi / 2
    for n1, n2 in normals:  # n1 cos a + n2 sin a ≥ 0  <=>  a on one side of the boundary angle
        if n1 >= 0 and n2 >= 0:
            continue
        if n1 < 0 and n2 < 0:
            return 0.0
        boundary = np.arctan2(-n1, n2) if n2 > 0 else np.arctan2(n1, -n2)
        lo, hi = (max(lo, boundary), hi) if n2 > 0 else (lo, min(hi, boundary))
    return max(hi - lo, 0.0) / (np.pi / 2)
