"""The delivery gridworld: layouts and classes by hand, paths exact against brute force and an
independent shortest-path solver, θ*'s strategies in every informative class, and the core's
pipeline (build -> teach) on its table."""
from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from teaching.core.build import PRESETS, build_table
from teaching.core.domain import get_domain
from teaching.core.rewards import reward
from teaching.core.sheet import make_sheet
from teaching.core.table import TrajectoryTable
from teaching.domains.gridworld import environments as E
from teaching.domains.gridworld import labels as L
from teaching.domains.gridworld.planner import pareto_paths
from teaching.domains.gridworld.world import CART, DOG, FREE, MUD, WALL
from teaching.teach import main as teach_main

GRIDWORLD = get_domain("gridworld")
RIGHT, UP, DOWN, LEFT = (0, 1), (-1, 0), (1, 0), (0, -1)  # written out again: the tie rule's order


def env_id(start_row, goal_row, obstacle, cart):
    return int(np.ravel_multi_index((start_row, goal_row, obstacle, cart), E.AXES))


def test_layouts_are_the_documented_ones():
    assert E.N_ENVIRONMENTS == 17460 == GRIDWORLD.n_environments
    # mud from column 3, thickness 1 in rows 0-2 and 2 below, gap in row 4; cart at (5, 6)
    y = E.get_yard(env_id(1, 2, 1 + 1 * 24 + 2 * 6 + 4, 4))
    assert y.start == (1, 0) and y.goal == (2, 7)
    expected = np.zeros((6, 8), int)
    expected[0:3, 3] = MUD
    expected[3, 3:5] = expected[5, 3:5] = MUD
    expected[5, 6] = CART
    np.testing.assert_array_equal(y.cells, expected)
    # the dog at (row 1, column 4) guarding a wall's gap; the wall's other gap is row 5
    y = E.get_yard(env_id(0, 0, 73 + 12 + 6 + 1, 0))
    assert [tuple(v) for v in np.argwhere(y.cells == DOG)] == [(1, 4)]
    assert np.flatnonzero(y.cells[:, 4] == WALL).tolist() == [3, 4]
    assert y.near_dog()[0:3, 3:6].sum() == 8 and y.near_dog().sum() == 8


def test_classes_from_shortest_paths_by_hand():
    row = lambda start, goal, obstacle, cart: E.yard_class(E.get_yard(env_id(start, goal, obstacle, cart)))  # noqa: E731
    assert row(2, 2, 0, 0) == E.OTHER  # an open yard
    assert row(2, 2, 1 + 6 * 1 + 0, 0) == E.MUD_CLASS  # thickness 2 from column 2, gap in row 0: in the way
    assert row(0, 0, 1 + 0, 0) == E.OTHER  # the gap is row 0, where the robot drives straight through
    assert row(2, 2, 73 + 6 + 2, 0) == E.DOG_CLASS  # the dog in row 2 of column 4, on the straight route
    assert row(5, 5, 73 + 6 + 0, 0) == E.OTHER  # ... while the robot crosses in row 5
    assert row(3, 3, 0, 1) == E.CART_CLASS  # a cart in the corner: fetching it is a detour
    assert row(0, 0, 0, 1) == E.OTHER  # a cart on the straight route along row 0
    counts = np.bincount(E.all_classes(), minlength=4)
    assert (counts > 1000).all(), counts  # every class well populated


def test_strategies_by_hand():
    # counts [carry, cart, mud, near dog] in a yard of each class
    phi = np.array([[9, 0, 2, 0], [11, 0, 0, 0], [9, 0, 0, 1], [11, 0, 0, 0], [4, 8, 0, 0], [9, 0, 0, 0], [7, 0, 0, 0]])
    cls = np.array([E.MUD_CLASS, E.MUD_CLASS, E.DOG_CLASS, E.DOG_CLASS, E.CART_CLASS, E.CART_CLASS, E.OTHER])
    assert L.strategy_labels(phi, cls).tolist() == [L.THROUGH_MUD, L.AROUND_MUD, L.PAST_DOG, L.AROUND_DOG,
                                                     L.FETCH_CART, L.CARRY, L.OTHER_DELIVER]


# --- exactness: brute force on small yards --------------------------------------------------
def all_paths(y: E.Yard):
    """Every path start -> goal that repeats no (cell, cart) state, with its counts, by depth-first
    enumeration (shares nothing with the planner but the yard)."""
    h, w = y.cells.shape
    near = y.near_dog()
    out = []

    def walk(r, c, has, seen, moves, phi):
        if (r, c) == y.goal:
            out.append((tuple(phi), tuple(moves)))
            return
        for k, (dr, dc) in enumerate((RIGHT, UP, DOWN, LEFT)):
            nr, nc = r + dr, c + dc
            if not (0 <= nr < h and 0 <= nc < w) or y.cells[nr, nc] in (WALL, DOG):
                continue
            nhas = has or y.cells[nr, nc] == CART
            if (nr, nc, nhas) in seen:
                continue
            step = [0 if has else 1, 1 if has else 0, int(y.cells[nr, nc] == MUD), int(near[nr, nc])]
            walk(nr, nc, nhas, seen | {(nr, nc, nhas)}, moves + [k], [a + b for a, b in zip(phi, step, strict=True)])

    start_has = y.cells[y.start] == CART
    walk(*y.start, start_has, {(*y.start, start_has)}, [], [0, 0, 0, 0])
    return out


def moves_of(path):
    steps = [(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(path)]
    return tuple((RIGHT, UP, DOWN, LEFT).index(s) for s in steps)


def small_yards(n, seed=0):
    rng = np.random.default_rng(seed)
    yards = []
    while len(yards) < n:
        h, w = rng.integers(3, 5), rng.integers(3, 5)
        cells = rng.choice([FREE, FREE, FREE, MUD, WALL], size=(h, w)).astype(np.int8)
        if rng.random() < 0.6:
            cells[rng.integers(h), rng.integers(w)] = DOG
        if rng.random() < 0.6:
            cells[rng.integers(h), rng.integers(w)] = CART
        start, goal = (int(rng.integers(h)), 0), (int(rng.integers(h)), w - 1)
        if cells[start] in (WALL, DOG) or cells[goal] in (WALL, DOG):
            continue
        y = E.Yard(-1, cells, start, goal)
        if all_paths(y):
            yards.append(y)
    return yards


def test_the_front_and_its_paths_match_brute_force_on_small_yards():
    thetas = -np.exp(np.random.default_rng(1).uniform(-2.3, 2.3, size=(200, 4)))
    for y in small_yards(60):
        paths = all_paths(y)
        phis = {p for p, _ in paths}
        front = sorted(p for p in phis if not any(q != p and all(a <= b for a, b in zip(q, p, strict=True))
                                                  for q in phis))
        got_phi, got_paths = pareto_paths(y)
        assert [tuple(p) for p in got_phi] == front, y
        for p, path in zip(front, got_paths, strict=True):
            assert moves_of(path) == min(m for q, m in paths if q == p)  # the tie rule: first move sequence
        # every θ: the best over the front is the best over every path
        best_all = reward(np.array([p for p, _ in paths], float)[None], thetas[:, None]).max(1)
        best_front = reward(got_phi.astype(float)[None], thetas[:, None]).max(1)
        np.testing.assert_array_equal(best_front, best_all)


# --- exactness: an independent solver on a built table ----------------------------------------
def dijkstra_best(y: E.Yard, theta: np.ndarray) -> float:
    """max θ·φ over paths, by scipy's Dijkstra on the (cell, cart) graph with edge cost -θ·Δφ."""
    h, w = y.cells.shape
    near = y.near_dog()
    node = lambda r, c, has: (r * w + c) * 2 + has  # noqa: E731
    rows, cols, cost = [], [], []
    for r, c, has in itertools.product(range(h), range(w), (0, 1)):
        if y.cells[r, c] in (WALL, DOG) or (r, c) == y.goal:
            continue
        for dr, dc in (RIGHT, UP, DOWN, LEFT):
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and y.cells[nr, nc] not in (WALL, DOG):
                nhas = int(has or y.cells[nr, nc] == CART)
                step = np.array([1 - has, has, y.cells[nr, nc] == MUD, near[nr, nc]], float)
                rows.append(node(r, c, has))
                cols.append(node(nr, nc, nhas))
                cost.append(-(theta @ step))
    graph = csr_matrix((cost, (rows, cols)), shape=(h * w * 2, h * w * 2))
    dist = dijkstra(graph, indices=node(*y.start, int(y.cells[y.start] == CART)))
    return -min(dist[node(*y.goal, 0)], dist[node(*y.goal, 1)])


def test_every_path_of_a_built_table_is_valid_and_optimal(gridworld_tiny_table):
    table = TrajectoryTable.load(gridworld_tiny_table)
    assert table.meta["domain"] == "gridworld" and table.domain is GRIDWORLD
    feats, thetas = np.asarray(table.features), np.asarray(table.thetas)
    for m, eid in enumerate(table.env_ids):
        y = E.get_yard(int(eid))
        near = y.near_dog()
        for n in range(table.n_thetas):
            cells = [divmod(int(v), 8) for v in table.controls[m, n]]
            path = [cells[0]] + [b for a, b in itertools.pairwise(cells) if b != a]
            assert path[0] == y.start and path[-1] == y.goal
            has, phi = y.cells[y.start] == CART, np.zeros(4)
            for a, b in itertools.pairwise(path):
                assert abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 and y.cells[b] not in (WALL, DOG)
                phi += [not has, has, y.cells[b] == MUD, near[b]]
                has = has or y.cells[b] == CART
            np.testing.assert_array_equal(feats[m, n], phi)  # the stored counts are the path's
            assert reward(feats[m, n], thetas[n]) == pytest.approx(dijkstra_best(y, thetas[n]), abs=1e-9)
        labels = L.strategy_labels(feats[m], np.full(table.n_thetas, table.env_class[m]))
        assert table.strategy[m].tolist() == labels.tolist()
    assert table.d_reward().min() >= 0


def test_theta_star_shows_both_strategies_of_every_informative_class():
    """On 400 yards of each informative class, drawn with a fixed seed: over all 17,460 yards the
    shares are mud 24 / 76 %, dog 25 / 75 %, cart 47 / 53 % (the whole set is 40 s of label-setting,
    these 1,200 yards 3 s), so the 5 % floor sits 9 standard errors below the smallest share."""
    star = np.asarray(GRIDWORLD.theta_star, float)
    cls = E.all_classes()
    rng = np.random.default_rng(0)
    for c in (E.MUD_CLASS, E.DOG_CLASS, E.CART_CLASS):
        picks = []
        for i in rng.choice(np.flatnonzero(cls == c), 400, replace=False):
            phi, _ = pareto_paths(E.get_yard(int(i)))
            picks.append(L.strategy_labels(phi[np.argmax(reward(phi.astype(float), star))], cls[i]))
        share = np.bincount(picks, minlength=8)[[2 * c, 2 * c + 1]] / len(picks)
        assert (share >= 0.05).all(), (E.CLASS_NAMES[c], share)
        assert share.sum() == 1  # every path of the class shows one of its two strategies


def test_the_core_teaches_from_a_gridworld_table(tmp_path):
    """The demo-sized table (1,200 yards x 200 θ: about 2 s) through the unchanged teach command."""
    path, out = tmp_path / "table", tmp_path / "teach"
    build_table(PRESETS["gridworld"], path)
    assert teach_main(["--table", str(path), "--out", str(out), "--no-progress"]) == 0
    tests = json.loads((out / "test_set.json").read_text())
    assert [t["cluster_name"] for t in tests] == [GRIDWORLD.cluster_names[c] for c in GRIDWORLD.test_clusters]
    grids = json.loads((out / "examples_per_cluster.json").read_text())["grids"]
    assert np.asarray(grids["exact"]).shape == (2, 4)  # rows: 1st / 2nd strategy; columns: mud, dog, cart, other
    # the contact sheet draws the yards: one panel per example and 4 per test
    seqs = json.loads((out / "sequences.json").read_text())["conditions"]
    n, no_tests = make_sheet(table_dir=path, teach_dir=out, out=tmp_path / "sheet.png")
    assert no_tests is None and n == sum(len(v["env_ids"]) for v in seqs.values()) + 4 * len(tests)
    assert (tmp_path / "sheet.png").stat().st_size > 50_000


def test_the_examples_grid_leaves_a_missing_strategy_blank():
    """"other" has one strategy where the other classes have two: its second row is no cluster, shown
    without a number (not "0 examples"); every real cluster shows its count."""
    from teaching.core.evaluation import cluster_grid  # noqa: PLC0415
    from teaching.core.plots import cell_labels  # noqa: PLC0415

    of = get_domain("gridworld").class_of_cluster
    grid = cluster_grid(np.arange(1, 8), of)  # counts 1..7 for the 7 clusters
    assert cell_labels(grid, of) == [["1", "3", "5", "7"], ["2", "4", "6", ""]]
    driving = get_domain("driving").class_of_cluster
    assert cell_labels(cluster_grid(np.zeros(8, int), driving), driving) == [["0"] * 4, ["0"] * 4]
