"""An independent reference for the whole BEC's facets and its smallest cover, sharing no code, rounding or
tolerance with teaching.core.bec: it checks SCOT's cover in tests/teaching/core/test_cover_reference.py.

* Normals from the table's features, unrounded (bec rounds to 12 decimals), in the positive orthant of θ*'s
  signs, each scaled to unit length.
* Facets by duality, not by Clarkson's method or redundancy LPs: with x0 strictly inside the region (its
  own Chebyshev-centre LP, interior-point method), each constraint g (a row, or an orthant bound e_i) is the
  point g / (g·x0) of the hyperplane y·x0 = 1, and the region's facets are exactly the vertices of those
  points' convex hull (qhull's ConvexHull); each is then confirmed by its own minimum over the region of
  every other row (:func:`minimum`), as qhull's rounding may make a vertex of a point a hair inside.
* The smallest cover by mixed-integer programming (SciPy's milp), where an environment holds a facet when
  one of its rows equals it to FACET_MATCH.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linprog, milp
from scipy.spatial import ConvexHull, HalfspaceIntersection

FACET_MATCH = 1e-10  # an environment's row and a facet further apart than this (max abs) are two constraints
IMPLIED = 1e-11  # a minimum above -IMPLIED (simplex units) counts as implied: 30x below the thinnest cut


def environment_normals(table, m: int) -> np.ndarray:
    """(K, D) the unit normals of environment row m's BEC in the orthant of θ*'s signs: (φ(θ*) - φ(θ)) ⊙ s."""
    phi = np.asarray(table.features[m], np.float64)
    diff = (phi[table.theta_star_index] - phi) * np.sign(np.asarray(table.theta_star, np.float64))
    norm = np.linalg.norm(diff, axis=1)
    keep = norm > 1e-9 * max(norm.max(initial=0.0), 1e-300)
    return diff[keep] / norm[keep, None]


def distinct(rows: np.ndarray) -> np.ndarray:
    """One row of ``rows`` (K, D), unrounded, for each that is distinct at 10 decimals (bec uses 12)."""
    _, first = np.unique(np.round(rows, 10) + 0.0, axis=0, return_index=True)
    return rows[np.sort(first)]


def minimum(rows: np.ndarray, c: np.ndarray, inside: np.ndarray) -> float:
    """min c·u over the region u ≥ 0, Σu = 1, rows·u ≥ 0, exactly as a linear program's answer is defined (the
    minimum over the region's vertices), with the vertices from qhull's halfspace intersection: an LP solver
    answers within its feasibility tolerance, which HiGHS holds no tighter than 1e-10 (and then missed a
    constraint of the region itself by 7e-10), while a vertex is exact to float64's rounding.  ``inside``
    (D,): a point strictly inside the region."""
    d = len(c)
    # on the simplex, u = (y, 1 - Σy): rows·u ≥ 0 reads (rows[:, :-1] - rows[:, -1])·y + rows[:, -1] ≥ 0;
    # qhull takes A y + b ≤ 0
    halfspaces = np.vstack([
        np.hstack([-(rows[:, :-1] - rows[:, -1:]), -rows[:, -1:]]),
        np.hstack([-np.eye(d - 1), np.zeros((d - 1, 1))]),  # y_i ≥ 0
        np.r_[np.ones(d - 1), -1.0][None],  # u_D = 1 - Σy ≥ 0
    ])
    y = HalfspaceIntersection(halfspaces, inside[:-1]).intersections
    vertices = np.hstack([y, 1.0 - y.sum(1, keepdims=True)])
    return float((vertices @ c).min())


def chebyshev_centre(rows: np.ndarray) -> tuple[np.ndarray, float]:
    """(x0, r): the point of the region deepest inside every row and orthant bound, and that depth."""
    k, d = rows.shape
    a_ub = np.vstack([np.hstack([-rows, np.ones((k, 1))]), np.hstack([-np.eye(d), np.ones((d, 1))])])
    res = linprog(np.r_[np.zeros(d), -1.0], A_ub=a_ub, b_ub=np.zeros(k + d), A_eq=np.r_[np.ones(d), 0.0][None],
                  b_eq=[1.0], bounds=[(None, None)] * (d + 1), method="highs-ipm")
    assert res.status == 0, res.message
    return res.x[:d], float(res.x[d])


def facets(rows: np.ndarray) -> tuple[np.ndarray, float]:
    """(the rows of ``rows`` (K, D, distinct) that are facets of their region, its inradius)."""
    x0, r = chebyshev_centre(rows)
    assert r > 0, "the region has no interior"
    d = rows.shape[1]
    generators = np.vstack([rows, np.eye(d)])
    points = generators / (generators @ x0)[:, None]
    # coordinates within the hyperplane y·x0 = 1: an orthonormal basis of x0's complement
    basis = np.linalg.svd(x0[None])[2][1:]
    hull = ConvexHull(points @ basis.T)
    vertices = np.unique(hull.vertices)
    found = vertices[vertices < len(rows)]  # the orthant bounds are no environment's constraints
    # qhull's vertices are candidates: within its rounding, a row a hair inside the hull may be one
    confirmed = [i for i in np.sort(found) if minimum(np.delete(rows, i, 0), rows[i], x0) < -IMPLIED]
    return rows[confirmed], r


def smallest_cover(env_rows: list[np.ndarray], facet_rows: np.ndarray) -> int:
    """The fewest environments whose rows hold every facet (milp over the E x F incidence)."""
    holds = np.array([[bool(len(rows)) and np.abs(rows - f).max(1).min() <= FACET_MATCH for f in facet_rows]
                      for rows in env_rows])
    assert holds.any(0).all(), "a facet no environment holds"
    res = milp(np.ones(len(env_rows)), constraints=LinearConstraint(holds.T.astype(float), lb=1),
               integrality=np.ones(len(env_rows)), bounds=Bounds(0, 1))
    assert res.status == 0, res.message
    return int(round(res.fun))
