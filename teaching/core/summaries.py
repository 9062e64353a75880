"""The field's example-based teachers, as selectors: SCOT, BEC scaffolding and HIGHLIGHTS.

They choose among the showable environments (θ*'s trajectory shows a strategy) from θ*'s
trajectories and the table's alternatives alone, with no learner model; each sequence reports
P(θ*) after each example under exact IRL (the learner these methods assume).  BECs come from
:mod:`teaching.core.bec` (the table's trajectories stand in for all trajectories).

* ``scot`` (Brown & Niekum 2019): the non-redundant constraints of the union of the showable
  environments' BECs, covered greedily: the environment holding most uncovered ones next (lowest
  environment id on ties), until every one is covered, so the chosen set's BEC is the whole's.
"""
from __future__ import annotations

import numpy as np

from . import bec
from .selection import SelectionContext, Sequence, showable
from .selectors import Selector, register_selector


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


def scot_cover(table) -> tuple[list[int], np.ndarray]:
    """SCOT's examples (table rows, in the order chosen) and the whole's non-redundant
    constraints (F, D) (u-space unit normals, :mod:`teaching.core.bec`).  SummaryError when no
    showable environment constrains θ* (every alternative is θ*'s own trajectory)."""
    rows, normals = showable_half_spaces(table)
    union = bec.union(normals)
    if not len(union):
        raise SummaryError("no showable environment constrains θ* (every alternative is θ*'s own trajectory): "
                           "nothing to teach")
    facets = bec.remove_redundant(union)
    chosen = greedy_cover(cover_matrix(normals, facets), np.asarray(table.env_ids)[rows])
    return [int(rows[c]) for c in chosen], facets


def _exact(ctx: SelectionContext, envs: list[int]) -> Sequence:
    return ctx.evaluated(envs, "exact")


def scot(ctx: SelectionContext) -> Sequence:
    return _exact(ctx, scot_cover(ctx.table)[0])


register_selector(Selector("scot", scot, doc="SCOT (Brown & Niekum 2019): greedy set cover of the BEC's "
                                             "non-redundant constraints"))
