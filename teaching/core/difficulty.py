"""How hard a test environment is (Lee, Admoni & Simmons 2021): the size of its BEC, a large one easy.

The size is exact: the (D−1)-volume of the environment's BEC on the simplex slice Σu = 1 of θ*'s orthant
(u = sign(θ*) ⊙ w, :mod:`teaching.core.bec`) as a fraction of the whole simplex, in [0, 1]: the region's
vertices and their convex hull's volume (qhull), or with 2 features the segment's length; a region without
interior has size 0.  It ranks environments as :func:`teaching.core.bec.bec_size`'s Monte-Carlo fraction of
the sphere does up to that estimate's noise, but has none: on the paper's demo table the Monte-Carlo tertiles lay
about one standard error apart at 100,000 samples, so the levels were the sampler's seed
(docs/decisions.md, "Test difficulty").  Its precision is float64's (a relative 1e-12 or better).

Levels are tertiles q1 ≤ q2 of the sizes (``numpy.quantile``, linear interpolation): "high" for size ≤ q1,
"medium" for q1 < size ≤ q2, "low" for size > q2 (an edge counts as the harder level).  A test is graded
against the eligible environments of every test cluster together (one scale for the whole set, as Lee et
al. grade), and only where its own cluster has none of the level on that scale, against its cluster's alone
(the test's ``"graded"``: "all" or "cluster").
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull

from . import bec

DIFFICULTIES = ("low", "medium", "high")  # easiest first: a large BEC first
ALL, CLUSTER = "all", "cluster"  # what a test was graded against: every test cluster's environments, or its own


def slice_size(normals: np.ndarray) -> float:
    """The exact size of the region ``normals`` (K, D) (u-space unit normals, bec.half_spaces) on the
    simplex Σu = 1, as a fraction of the simplex's (D−1)-volume, in [0, 1] (module docstring)."""
    normals = np.asarray(normals, np.float64)
    if not len(normals):
        return 1.0
    d = normals.shape[1]
    inside, depth = bec.interior_point(normals)
    if depth <= 0:
        return 0.0
    vertices = bec._vertices(normals, inside)
    if d == 2:
        return float(np.ptp(vertices[:, 0]))
    # in the coordinates y = u[:-1] the simplex is {y ≥ 0, Σy ≤ 1}, of volume 1 / (D−1)!
    return min(1.0, float(ConvexHull(vertices[:, :-1]).volume) * math.factorial(d - 1))


def environment_sizes(table, rows) -> np.ndarray:
    """(E,) :func:`slice_size` of the BEC of each table row in ``rows`` (E,), θ* the table's."""
    signs = bec.weight_signs(table.theta_star)
    for m in (int(m) for m in rows):
        if ("bec size", m) not in table.memo:  # each level, and the designer's counts, grade the same rows
            table.memo["bec size", m] = slice_size(bec.half_spaces(table.features[m], signs, table.theta_star_index))
    return np.array([table.memo["bec size", int(m)] for m in rows])


def difficulty_levels(size: np.ndarray) -> tuple[np.ndarray, tuple[float, float]]:
    """(level (E,) index into DIFFICULTIES, (q1, q2)): the tertiles of ``size`` (E,) (numpy.quantile at
    1/3 and 2/3); "high" for size ≤ q1, "medium" for q1 < size ≤ q2, "low" for size > q2.  E ≥ 1."""
    size = np.asarray(size, np.float64)
    q1, q2 = (float(q) for q in np.quantile(size, [1 / 3, 2 / 3]))
    return np.where(size <= q1, 2, np.where(size <= q2, 1, 0)), (q1, q2)


@dataclass(frozen=True)
class Grading:
    """The levels of some environments on both scales (module docstring).

    size: {row: exact BEC size}.  rows: {test cluster: its rows, in table order}.  edges: {ALL: (q1, q2)
    over every row, cluster: (q1, q2) over its rows}.  level: {(ALL or cluster, row): index into
    DIFFICULTIES}."""

    size: dict[int, float]
    rows: dict[int, list[int]]
    edges: dict
    level: dict

    def candidates(self, cluster: int, difficulty: str) -> list[tuple[str, list[int]]]:
        """[(scale, rows)]: the cluster's rows of ``difficulty`` graded against all clusters, then against
        its own: the order a test tries them in."""
        wanted = DIFFICULTIES.index(difficulty)
        return [(scale, [m for m in self.rows[cluster] if self.level[scale, m] == wanted])
                for scale in (ALL, cluster)]

    def counts(self, cluster: int) -> str:
        """How many of the cluster's rows each level has on both scales, in words."""
        def on(scale):
            n = np.bincount([self.level[scale, m] for m in self.rows[cluster]], minlength=3)
            return ", ".join(f"{k} {d}" for k, d in zip(n.tolist(), DIFFICULTIES, strict=True))

        return f"{on(ALL)} against every test cluster's sizes, {on(cluster)} against its own"

    def record(self, row: int, scale) -> dict:
        """What a graded test keeps of its grading: its size, the tertiles it was graded by, and which."""
        return {"bec_size": self.size[row], "bec_tertiles": list(self.edges[scale]),
                "graded": ALL if scale == ALL else CLUSTER}


def grade(table, rows: dict[int, list[int]]) -> Grading:
    """The levels of ``rows`` ({test cluster: table rows}) on both scales (module docstring)."""
    every = sorted({int(m) for ms in rows.values() for m in ms})
    size = dict(zip(every, environment_sizes(table, every).tolist(), strict=True))
    edges, level = {}, {}
    for scale, members in [(ALL, every), *rows.items()]:
        if not members:
            continue
        lv, edges[scale] = difficulty_levels([size[m] for m in members])
        level.update({(scale, int(m)): int(v) for m, v in zip(members, lv, strict=True)})
    return Grading(size, {c: [int(m) for m in ms] for c, ms in rows.items()}, edges, level)


def describe(tests: list[dict]) -> list[str]:
    """One line per graded test (a test set's dicts): its level, exact size and the tertiles it was graded by."""
    lines = []
    for t in tests:
        if "difficulty" not in t:
            continue
        q1, q2 = t["bec_tertiles"]
        against = "every test cluster's" if t.get("graded") == ALL else "its own cluster's"
        name = t.get("cluster_name", t.get("cluster"))
        lines.append(f"test {name} (environment {t['env_id']}): {t['difficulty']}, "
                     f"BEC size {t['bec_size']:.4g} against {against} tertiles {q1:.4g} and {q2:.4g} "
                     "(standard error 0 (exact sizes): no sampling)")
    return lines
