"""The field's example-based teachers, as selectors: SCOT, BEC scaffolding and HIGHLIGHTS.

They choose among the showable environments (θ*'s trajectory shows a strategy) from θ*'s
trajectories and the table's alternatives alone, with no learner model; each sequence reports
P(θ*) after each example under exact IRL (the learner these methods assume).  BECs come from
:mod:`teaching.core.bec` (the table's trajectories stand in for all trajectories).

* ``scot`` (Brown & Niekum 2019): the non-redundant constraints of the union of the showable
  environments' BECs, covered greedily: the environment holding most uncovered ones next (lowest
  environment id on ties), until every one is covered, so the chosen set's BEC is the whole's.
* ``bec-scaffold`` (Lee, Admoni & Simmons 2021): SCOT's examples ordered easy to hard by the
  size of each one's own BEC (a large region is easy: many weights explain it), with ``k``
  scaffolding examples from the easier clusters of BEC size placed before the harder ones.
* ``highlights`` (Amir & Amir 2018): the ``k`` most important environments, importance being what
  θ* loses by the worst of the table's trajectories there, one per θ* strategy cluster.
"""
from __future__ import annotations

import numpy as np

from . import bec
from .conditions import SelectionContext
from .rewards import reward
from .selection import Sequence, showable, theta_star_clusters
from .selectors import Param, Selector, integer_at_least, register_selector


class SummaryError(ValueError):
    """A table on which an example-based selector has nothing to choose (one-line message)."""


def cover_matrix(normals: list[np.ndarray], facets: np.ndarray) -> np.ndarray:
    """(E, F) bool: whether environment e's half-spaces (normals[e], (K_e, D) unit, rounded) hold
    facet f (facets (F, D), rows of the same rounding): equal up to positive scaling."""
    index = {row.tobytes(): f for f, row in enumerate(np.ascontiguousarray(facets))}
    out = np.zeros((len(normals), len(facets)), bool)
    for e, rows in enumerate(normals):
        for row in np.ascontiguousarray(rows):
            f = index.get(row.tobytes())
            if f is not None:
                out[e, f] = True
    return out


def greedy_cover(covers: np.ndarray, env_ids: np.ndarray) -> list[int]:
    """Rows of ``covers`` (E, F) bool chosen greedily until every column is covered: most uncovered
    columns first, the lowest ``env_ids`` (E,) on ties.  SummaryError if a column has no row."""
    if len(covers) and not covers.any(0).all() or not len(covers) and covers.shape[1]:
        raise SummaryError("no set of environments holds every constraint of the whole BEC")
    order = np.argsort(env_ids, kind="stable")  # ties go to the first in this order
    left = np.ones(covers.shape[1], bool)
    chosen: list[int] = []
    while left.any():
        gain = covers[order][:, left].sum(1)
        chosen.append(int(order[int(np.argmax(gain))]))
        left &= ~covers[chosen[-1]]
    return chosen


def showable_half_spaces(table) -> tuple[np.ndarray, list[np.ndarray]]:
    """(rows (E,) of the showable environments, their BEC normals); SummaryError if none is showable."""
    rows = np.flatnonzero(showable(table))
    if not len(rows):
        raise SummaryError("the table has no showable environment (θ*'s trajectory shows no strategy anywhere)")
    signs = bec.weight_signs(table.theta_star)
    return rows, [bec.half_spaces(table.features[m], signs, table.theta_star_index) for m in rows]


def scot_cover(table, showable_bec: tuple[np.ndarray, list[np.ndarray]] | None = None) -> tuple[list[int], np.ndarray]:
    """SCOT's examples (table rows, in the order chosen) and the whole's non-redundant
    constraints (F, D) (u-space unit normals, :mod:`teaching.core.bec`).  showable_bec: what
    :func:`showable_half_spaces` gives, if already at hand.  SummaryError when no showable
    environment constrains θ* (every alternative is θ*'s own trajectory)."""
    rows, normals = showable_bec or showable_half_spaces(table)
    union = bec.union(normals)
    if not len(union):
        raise SummaryError("no showable environment constrains θ* (every alternative is θ*'s own trajectory): "
                           "nothing to teach")
    facets = bec.remove_redundant(union)
    chosen = greedy_cover(cover_matrix(normals, facets), np.asarray(table.env_ids)[rows])
    return [int(rows[c]) for c in chosen], facets


def _exact(ctx: SelectionContext, envs: list[int]) -> Sequence:
    return ctx.evaluated(envs, "exact")


def _showable_bec(ctx: SelectionContext) -> tuple[np.ndarray, list[np.ndarray]]:
    return ctx.shared("showable half-spaces", lambda: showable_half_spaces(ctx.table))


def _scot_cover(ctx: SelectionContext) -> list[int]:
    return ctx.shared("scot cover", lambda: scot_cover(ctx.table, _showable_bec(ctx)))[0]


def scot(ctx: SelectionContext) -> Sequence:
    return _exact(ctx, _scot_cover(ctx))


def size_levels(size: np.ndarray, env_ids: np.ndarray, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """(order (E,): easiest first, by size descending then id; level (E,) 0 = easiest .. levels - 1):
    equal-count clusters of BEC size by rank, so ties in size cannot empty a cluster."""
    order = np.lexsort((env_ids, -size))
    level = np.empty(len(size), np.int64)
    level[order] = np.arange(len(size)) * levels // max(len(size), 1)
    return order, level


def scaffolded(cover: list[int], size: np.ndarray, env_ids: np.ndarray, *, k: int, levels: int) -> list[int]:
    """Positions (into size (E,) / env_ids (E,)) of the cover and k scaffolding examples, easy to hard.

    Scaffolding example i comes from level i mod (levels - 1) (never the hardest level): the
    environment not yet chosen whose size is nearest that level's median (lowest id on ties).
    """
    order, level = size_levels(size, env_ids, levels)
    chosen = list(cover)
    for i in range(k):
        members = [e for e in np.flatnonzero(level == i % max(levels - 1, 1)) if e not in chosen]
        if not members:
            continue
        median = np.median(size[level == i % max(levels - 1, 1)])
        chosen.append(min(members, key=lambda e: (abs(size[e] - median), env_ids[e])))
    return sorted(chosen, key=lambda e: (-size[e], env_ids[e]))


def importance(table) -> np.ndarray:
    """(M,) θ*'s reward of its own trajectory minus that of the worst of the table's trajectories in
    each environment (≥ 0, θ*-reward units: what a wrong choice there can cost)."""
    out = np.empty(table.n_envs)
    for lo in range(0, table.n_envs, 1024):
        r = reward(table.features[lo:lo + 1024], table.theta_star)  # (m, N)
        out[lo:lo + 1024] = r[:, table.theta_star_index] - r.min(1)
    return out


def highlights_envs(value: np.ndarray, clusters: np.ndarray, env_ids: np.ndarray, eligible: np.ndarray,
                    k: int) -> list[int]:
    """Rows of the k highest ``value`` (M,) among ``eligible`` (M,) bool (lowest id on ties), skipping
    one whose θ* cluster (clusters (M,)) an earlier pick has: at most one example per strategy."""
    chosen, seen = [], set()
    for m in np.lexsort((env_ids, -value)):
        if eligible[m] and int(clusters[m]) not in seen:
            chosen.append(int(m))
            seen.add(int(clusters[m]))
            if len(chosen) == k:
                break
    return chosen


def bec_scaffold(ctx: SelectionContext, k: int, levels: int, samples: int) -> Sequence:
    cover = _scot_cover(ctx)
    rows, normals = _showable_bec(ctx)
    position = {int(r): i for i, r in enumerate(rows)}
    ids = np.asarray(ctx.table.env_ids)[rows]
    order = scaffolded([position[c] for c in cover], bec.bec_sizes(normals, samples), ids, k=k, levels=levels)
    return _exact(ctx, [int(rows[e]) for e in order])


def highlights(ctx: SelectionContext, k: int) -> Sequence:
    table = ctx.table
    return _exact(ctx, highlights_envs(importance(table), theta_star_clusters(table), np.asarray(table.env_ids),
                                       ctx.eligible, k))


register_selector(Selector("scot", scot, doc="SCOT (Brown & Niekum 2019): greedy set cover of the BEC's "
                                             "non-redundant constraints"))
register_selector(Selector(
    "bec-scaffold", bec_scaffold,
    params={"k": Param(2, integer_at_least(0), "scaffolding examples added to SCOT's"),
            "levels": Param(3, integer_at_least(2), "clusters of BEC size (equal counts by rank)"),
            "samples": Param(bec.MC_SAMPLES, integer_at_least(1000), "Monte-Carlo samples per BEC size")},
    doc="BEC summary with scaffolding (Lee, Admoni & Simmons 2021): SCOT's cover easy to hard, with "
        "easier examples first"))
register_selector(Selector(
    "highlights", highlights, params={"k": Param(5, integer_at_least(1), "examples at most")},
    doc="HIGHLIGHTS (Amir & Amir 2018): the most important environments, one per θ* strategy cluster"))
