"""SCOT, BEC scaffolding and HIGHLIGHTS: by hand on tests/teaching/core/hand_bec_table.py, and on the
tiny tables of both domains against brute force and linear programming."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from teaching.core import bec
from teaching.core.conditions import SelectionContext, condition_sequence
from teaching.core.selection import theta_star_clusters
from teaching.core.selectors import check_params, get_selector
from teaching.core.summaries import (
    SummaryError,
    cover_matrix,
    greedy_cover,
    importance,
    scot_cover,
    showable_half_spaces,
)
from teaching.core.table import TrajectoryTable
from tests.conftest import TINY_PRESETS, tiny_preset_table
from tests.teaching.core.hand_bec_table import hand_bec_table

BRUTE_FORCE_LIMIT = 200_000  # subsets tried before a brute force gives up


def smallest_cover(covers: np.ndarray) -> int | None:
    """The fewest rows of covers (E, F) bool covering every column, by brute force (None: too many
    subsets).  A row that alone holds some column is in every cover; the rest are tried by size."""
    forced = {int(np.flatnonzero(covers[:, f])[0]) for f in range(covers.shape[1]) if covers[:, f].sum() == 1}
    left = ~covers[sorted(forced)].any(0) if forced else np.ones(covers.shape[1], bool)
    useful = [e for e in range(len(covers)) if e not in forced and covers[e, left].any()]
    tried = 0
    for k in range(len(useful) + 1):
        for subset in itertools.combinations(useful, k):
            tried += 1
            if tried > BRUTE_FORCE_LIMIT:
                return None
            if not left.any() or covers[list(subset)][:, left].any(0).all():
                return len(forced) + k
    return None


# --- by hand --------------------------------------------------------------------------------
def test_scot_by_hand_covers_the_two_tight_constraints_with_the_smallest_cover():
    table = hand_bec_table()
    envs, facets = scot_cover(table)
    # whole BEC [33.69°, 53.13°]: E2's (-2,3) and E3's (2,-1.5) (tests/teaching/core/test_bec.py).
    # E0 and E1 hold neither; E2 and E3 one each: E2 first (a tie, the lower id 12), then E3
    assert envs == [2, 3]
    rows, normals = showable_half_spaces(table)
    covers = cover_matrix(normals, facets)
    np.testing.assert_array_equal(covers, [[False, False], [False, False], [True, False], [False, True]])
    assert smallest_cover(covers) == len(envs) == 2
    seq = condition_sequence(table, "scot")[0]
    assert seq.envs == [2, 3] and len(seq.p) == 2


def test_greedy_cover_takes_the_most_uncovered_then_the_lowest_id():
    covers = np.array([[1, 1, 0, 0], [0, 0, 1, 1], [1, 1, 1, 0], [0, 0, 0, 1]], bool)
    # row 2 covers 3 (most), then rows 1 and 3 both cover column 3: ids 7 < 9, so row 3
    assert greedy_cover(covers, np.array([5, 9, 6, 7])) == [2, 3]
    with pytest.raises(SummaryError, match="no set of environments"):
        greedy_cover(np.zeros((2, 1), bool), np.array([1, 2]))


def test_scot_errors_in_one_line_where_no_cover_exists():
    table = hand_bec_table()
    table.features = np.repeat(table.features[:, :1], table.n_thetas, axis=1)  # every θ takes θ*'s
    with pytest.raises(SummaryError, match="nothing to teach") as info:
        condition_sequence(table, "scot")
    assert "\n" not in str(info.value)
    table = hand_bec_table(theta_star_clusters=(8, 8, 8, 8))  # the domain's "no strategy" everywhere
    with pytest.raises(SummaryError, match="no showable environment"):
        condition_sequence(table, "scot")


# --- the tiny tables of both domains --------------------------------------------------------
@pytest.fixture(scope="module", params=list(TINY_PRESETS))
def tiny(request, tmp_path_factory):
    return TrajectoryTable.load(tiny_preset_table(tmp_path_factory, request.param))


def test_scot_examples_hold_the_whole_bec_and_no_smaller_set_does(tiny):
    envs, facets = scot_cover(tiny)
    rows, normals = showable_half_spaces(tiny)
    whole = bec.union(normals)
    chosen = bec.union([normals[int(np.flatnonzero(rows == e)[0])] for e in envs])
    # the non-redundant constraints hold the whole, and the chosen set's BEC implies each of them (LP)
    assert bec.implies(facets, whole)
    assert bec.implies(chosen, facets)
    assert len(set(envs)) == len(envs) and set(envs) <= set(rows.tolist())
    # any set with the whole's BEC holds every facet among its constraints (a facet of an intersection is
    # one of its half-spaces): the smallest cover of the facets is the smallest such set
    smallest = smallest_cover(cover_matrix(normals, facets))
    # both tiny tables are small enough for the brute force (a table that is not belongs in another test)
    assert smallest is not None, f"more than {BRUTE_FORCE_LIMIT:,} subsets to brute-force"
    assert len(envs) == smallest


def test_highlights_importance_and_order_by_hand():
    table = hand_bec_table(theta_star_clusters=(0, 1, 2, 1))
    # θ* = (-1,-1) earns -6 with (3,3); its worst of the table's trajectories: E0 (2,5) or (5,2) -7,
    # E1 (2,6) -8, E2 (1,6) -7, E3 (9,0) -9: importance 1, 2, 1, 3
    np.testing.assert_allclose(importance(table), [1, 2, 1, 3])
    # by importance E3, E1, E0, E2 (E0 before E2: the lower id); E1 shares E3's cluster 1: skipped
    assert condition_sequence(table, "highlights")[0].envs == [3, 0, 2]
    assert condition_sequence(table, "highlights", params={"k": 2})[0].envs == [3, 0]


def test_bec_scaffold_orders_scot_easy_to_hard_with_easier_examples_added():
    table = hand_bec_table()
    # sizes (test_bec.py): E0 .4097, E1 .4209, E2 .6257, E3 .2952; SCOT's cover E2, E3
    assert condition_sequence(table, "bec-scaffold", params={"k": 0})[0].envs == [2, 3]
    # levels of 2 by rank: E2, E1 easy; E0, E3 hard.  One scaffold from the easy level, nearest its
    # median (.5233): E1 (.4209, off by .1024; E2 is in the cover) -> sizes .6257, .4209, .2952
    assert condition_sequence(table, "bec-scaffold", params={"k": 1, "levels": 2})[0].envs == [2, 1, 3]
    assert condition_sequence(table, "bec-scaffold", params={"k": 1, "levels": 2})[0].envs == \
        condition_sequence(table, "bec-scaffold", params={"k": 1, "levels": 2})[0].envs


def test_bec_scaffold_and_highlights_on_the_tiny_tables(tiny):
    cover = scot_cover(tiny)[0]
    seq = condition_sequence(tiny, "bec-scaffold", params={"k": 2, "samples": 20_000})[0].envs
    assert set(cover) <= set(seq) and len(seq) <= len(cover) + 2 and len(set(seq)) == len(seq)
    rows, normals = showable_half_spaces(tiny)
    size = dict(zip(rows.tolist(), bec.bec_sizes(normals, 20_000), strict=True))
    assert [size[e] for e in seq] == sorted((size[e] for e in seq), reverse=True)  # easy to hard
    envs = condition_sequence(tiny, "highlights", params={"k": 3})[0].envs
    clusters = theta_star_clusters(tiny)
    assert len(envs) <= 3 and len(set(clusters[envs].tolist())) == len(envs)
    assert list(importance(tiny)[envs]) == sorted(importance(tiny)[envs], reverse=True)


def test_one_run_covers_once_for_scot_and_bec_scaffold(monkeypatch):
    """SCOT's cover is bec-scaffold's first step: in one run (a teach with both) it is found once,
    and each sequence is what the selector gives alone."""
    table = hand_bec_table()
    alone = {name: condition_sequence(table, name)[0].envs for name in ("scot", "bec-scaffold")}
    calls = []
    real = bec.remove_redundant
    monkeypatch.setattr(bec, "remove_redundant", lambda *a, **k: calls.append(1) or real(*a, **k))
    ctx = SelectionContext(table)
    together = {name: get_selector(name).select(ctx, **check_params(name)).envs for name in alone}
    assert together == alone and len(calls) == 1


@pytest.mark.parametrize("name, params, message", [
    ("highlights", {"k": 0}, "selector 'highlights': parameter 'k': must be an integer >= 1, got 0"),
    ("highlights", {"k": 2.5}, "selector 'highlights': parameter 'k': must be an integer >= 1, got 2.5"),
    ("bec-scaffold", {"levels": 1}, "selector 'bec-scaffold': parameter 'levels': must be an integer >= 2"),
    ("bec-scaffold", {"samples": "many"}, "selector 'bec-scaffold': parameter 'samples': "),
    ("scot", {"k": 1}, "selector 'scot': unknown parameter 'k'; it takes no parameters"),
    ("sco", {}, "unknown condition 'sco'; choose from "),
])
def test_bad_selector_parameters_get_one_line_errors(name, params, message):
    with pytest.raises(ValueError) as info:
        condition_sequence(hand_bec_table(), name, params=params)
    assert str(info.value).startswith(message) and "\n" not in str(info.value)
