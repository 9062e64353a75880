"""A domain built from the building blocks alone (tests/teaching/small_grid_domain.py) goes through the
core's pipeline: its table builds, teach selects sequences and a test set covering both its test
clusters, its paths are each θ's best among its front; and the blocks' defaults hold for any number
of classes.  The domain is registered only inside these tests (small_grid_domain.registered)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from teaching.core.base import stratified_sample
from teaching.core.build import CORE_DIR, build_table, code_fingerprint
from teaching.core.checkdomain import CHECKS, ROOT, check_domain
from teaching.core.domain import domain_names, get_domain
from teaching.core.rewards import reward
from teaching.core.scenecolours import STATIC
from teaching.core.table import TrajectoryTable
from teaching.domains import _grid
from teaching.teach import main as teach_main
from tests.conftest import built_once
from tests.teaching import small_grid_domain as small


def built_small_grid(tmp_path_factory):
    """(table, teach output) of the small grid's tiny preset, built once per run (the domain must be
    registered around this call and around every use of the table)."""
    preset = small.DOMAIN.presets[0]
    table = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))

    def teach(out):
        assert teach_main(["--table", str(table), "--out", str(out), "--no-progress"]) == 0

    return table, built_once(tmp_path_factory, f"{preset.name}-teach", teach)


@pytest.fixture
def small_grid():
    with small.registered() as domain:
        yield domain
    assert small.NAME not in domain_names()  # gone again: loops over domain_names() never meet it


def test_it_builds_and_teaches_with_a_test_for_each_test_cluster(small_grid, tmp_path_factory):
    table_dir, teach_dir = built_small_grid(tmp_path_factory)
    table = TrajectoryTable.load(table_dir)
    assert table.domain is get_domain(small.NAME) and table.controls.shape[2:] == small_grid.trajectory_shape
    tests = json.loads((teach_dir / "test_set.json").read_text())
    assert sorted(t["cluster"] for t in tests) == sorted(small_grid.test_clusters)
    sequences = json.loads((teach_dir / "sequences.json").read_text())
    assert sequences["table"]["content_hash"] == table.meta["content_hash"] and sequences["conditions"]


def test_every_stored_path_is_its_thetas_best_and_has_its_counts(small_grid, tmp_path_factory):
    table = TrajectoryTable.load(built_small_grid(tmp_path_factory)[0])
    thetas = np.asarray(table.thetas)
    for m in range(0, len(table.env_ids), 37):
        cells, start, goal = small.cells_of(int(table.env_ids[m]))
        phi, _ = small_grid.front(int(table.env_ids[m]))
        best = reward(phi[None].astype(float), thetas[:, None]).max(axis=1)
        np.testing.assert_allclose(reward(np.asarray(table.features[m]), thetas), best)
        for n in (0, len(thetas) - 1):
            path = np.asarray(table.controls[m, n], np.int64)
            rows, cols = path // small.WIDTH, path % small.WIDTH
            assert (rows[0], cols[0]) == start and (rows[-1], cols[-1]) == goal
            entered = cells[rows[1:], cols[1:]][np.diff(path) != 0]  # the cells it moved into
            assert list(table.features[m, n]) == [len(entered), (entered == small.PUDDLE).sum(),
                                                  (entered == small.SAND).sum()]


def test_it_passes_check_domain(small_grid):
    """Every contract check-domain knows, on the domain's own preset; its scene (served from the tests'
    static folder beside the project's) read through the grid scene base it imports."""
    static = (ROOT / "tests" / "browser" / "static" / "studyapp", STATIC)
    results = list(check_domain(small_grid, n_envs=48, static=static))
    assert [r.check for r in results] == list(CHECKS)
    assert all(r.ok for r in results), [line for r in results for line in r.failures]
    palette = next(r for r in results if r.check == "palette")
    assert "the 9 colours the scene reads" in palette.summary  # its 6 and the grid base's grid, path, text


def test_the_stratified_sample_shares_any_number_of_classes_evenly():
    assert np.bincount(small.DOMAIN.all_classes[small.DOMAIN.stratified_sample(10, seed=1)]).tolist() == [5, 5]
    classes = np.repeat([0, 1, 2], 20)
    assert np.bincount(classes[stratified_sample(classes, 3, 9, seed=0)]).tolist() == [3, 3, 3]
    with pytest.raises(ValueError, match=r"\[3, 60\]"):
        stratified_sample(classes, 3, 2)


def test_the_code_fingerprint_covers_the_shared_grid_code():
    gridworld = get_domain("gridworld")
    assert _grid.ROOT in gridworld.code_roots and small.DOMAIN.code_roots[1:] == (_grid.ROOT,)
    assert code_fingerprint("gridworld") == code_fingerprint(roots=(CORE_DIR, *gridworld.code_roots))
    assert code_fingerprint("gridworld") != code_fingerprint(roots=(CORE_DIR, gridworld.code_root))
