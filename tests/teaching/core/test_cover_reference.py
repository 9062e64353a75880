"""SCOT's and bec-scaffold's covers against an independent reference (tests/teaching/core/bec_reference.py:
unrounded normals, facets by duality, its own minima and a MILP) on every shipped kind of table: the
chosen set's BEC implies every facet of the whole, each checked by its own linear program, and SCOT's
cover is as small as the smallest cover the MILP finds."""
from __future__ import annotations

import numpy as np
import pytest

from teaching.core import bec
from teaching.core.conditions import condition_sequence
from teaching.core.selection import showable
from teaching.core.summaries import scot_cover
from teaching.core.table import TrajectoryTable
from tests.teaching.core import bec_reference as ref
from tests.teaching.domains.worlds.shipped import shipped
from tests.teaching.domains.worlds.shipped import tiny_table as world_tiny_table

TABLES = ["tiny", "gridworld-tiny", "gridworld", "demo", "taxi-tiny"]


@pytest.fixture(scope="module", params=TABLES)
def table(request, tmp_path_factory):
    name = request.param
    if name == "taxi-tiny":
        with shipped("taxi") as taxi:
            yield TrajectoryTable.load(world_tiny_table(tmp_path_factory, taxi))
        return
    fixture = {"tiny": "tiny_table", "gridworld-tiny": "gridworld_tiny_table", "gridworld": "gridworld_table",
               "demo": "demo_table"}[name]
    yield TrajectoryTable.load(request.getfixturevalue(fixture))


@pytest.fixture(scope="module")
def reference(table):
    """(showable rows, each one's unrounded normals, the whole's facets, its inradius)."""
    rows = np.flatnonzero(showable(table))
    normals = [ref.environment_normals(table, int(m)) for m in rows]
    whole = ref.distinct(np.vstack(normals))
    facets, inradius = ref.facets(whole)
    return rows, normals, facets, inradius


def _implies(chosen: list[int], rows: np.ndarray, normals: list[np.ndarray], facets: np.ndarray) -> list[float]:
    """Each facet's minimum over the region of the chosen environments' rows (≥ -IMPLIED: implied), the
    linear program of each facet against the chosen set solved exactly (ref.minimum)."""
    position = {int(r): i for i, r in enumerate(rows)}
    region = np.vstack([normals[position[m]] for m in chosen])
    inside, depth = ref.chebyshev_centre(region)
    assert depth > 0
    return [ref.minimum(region, f, inside) for f in facets]


def test_the_reference_and_the_project_find_the_same_facets(table, reference):
    _, normals, facets, inradius = reference
    found = bec.facets(bec.union([bec.unit_normals(n) for n in normals]))
    assert found.uncertain == 0
    assert len(found.normals) == len(facets), (len(found.normals), len(facets))
    for f in facets:  # the same constraints, each to the project's 12 decimals
        assert np.abs(found.normals - f).max(1).min() <= 1e-12
    assert found.inradius == pytest.approx(inradius, rel=1e-6)


@pytest.mark.parametrize("selector", ["scot", "bec-scaffold"])
def test_the_cover_implies_every_facet_of_the_whole(table, reference, selector):
    rows, normals, facets, _ = reference
    if selector == "scot":
        chosen = scot_cover(table)[0]
    else:  # few Monte-Carlo samples: the sizes only order the examples, the cover is SCOT's either way
        chosen = condition_sequence(table, "bec-scaffold", params={"samples": 20_000})[0].envs
    minima = _implies(chosen, rows, normals, facets)
    assert min(minima) >= -ref.IMPLIED, [m for m in minima if m < -ref.IMPLIED]


def test_scots_cover_is_the_smallest(table, reference):
    rows, normals, facets, _ = reference
    assert len(scot_cover(table)[0]) == ref.smallest_cover(normals, facets)
