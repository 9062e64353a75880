"""Show-the-way tests on the shipped worlds (too small for a 4-option choice test): `teach --tests show`
writes them on each world's tiny preset, the teach reader and the contact sheet take them, and on the
taxi each test is checked by replaying every candidate's way through the domain's scoring of a shown
trajectory (an independent path to θ*-regret)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from teaching.core.sheet import make_sheet
from teaching.core.showtests import MIN_SHARE, select_show_tests
from teaching.core.table import TrajectoryTable
from teaching.core.teachout import TeachOutputError, check_against, read_teach
from tests.teaching.domains.worlds.shipped import NAMES, shipped, teach_show, tiny_table
from tests.teaching.domains.worlds.test_world_files import actions_of


@pytest.mark.parametrize("name", NAMES)
def test_teach_writes_show_tests_for_each_shipped_world(name, tmp_path_factory, tmp_path):
    with shipped(name) as domain:
        table_dir, out = teach_show(tmp_path_factory, domain)
        table = TrajectoryTable.load(table_dir)
        output = read_teach(out)
        check_against(output, table)
        n_panels, no_tests = make_sheet(table_dir=table_dir, teach_dir=out, out=tmp_path / "sheet.png", dpi=40)
    tests = json.loads((out / "test_set.json").read_text())
    assert tests and output.tests == tests and output.test_kind == "show" and no_tests is None
    assert all(t["kind"] == "show" and "options" not in t and t["share_worse"] >= MIN_SHARE for t in tests)
    clusters = [t["cluster"] for t in tests]
    assert clusters == sorted(set(clusters)) and set(clusters) <= set(domain.test_clusters)
    trained = {e for c in output.conditions.values() for e in c}
    assert not trained & {t["env_id"] for t in tests}
    assert "predicted" not in json.loads((out / "matrix.json").read_text())  # choices among options: none here
    # θ*'s way in every training example, and one panel (θ*'s way) per show test
    assert n_panels == sum(len(c) for c in output.conditions.values()) + len(tests)


def test_each_taxi_test_is_passed_only_by_theta_stars_way(tmp_path_factory):
    with shipped("taxi") as domain:
        table = TrajectoryTable.load(tiny_table(tmp_path_factory, domain))
        tests = select_show_tests(table, [], seed=0)
        assert tests == select_show_tests(table, [], seed=0)
        terminal = [i for i, f in enumerate(domain.world.features) if f.terminal]
        row_of = {int(e): m for m, e in enumerate(table.env_ids)}
        for t in tests:
            m = row_of[t["env_id"]]
            assert int(table.strategy[m, 0]) == t["cluster"]
            regrets = []
            for j in range(table.n_thetas):
                rows = domain.path_rows(table.states(m, np.array([j]))[0])
                ended_by_exit = not np.asarray(table.features[m, j])[terminal].any()
                regrets.append(domain.score_shown(t["env_id"], actions_of(rows, ended_by_exit))["regret"])
            assert regrets[0] == pytest.approx(0, abs=1e-9)  # θ*'s own way passes
            # the share of candidates whose way a participant could show and fail with
            assert np.mean(np.array(regrets) > 1e-9) == pytest.approx(t["share_worse"])
        assert [t["cluster"] for t in tests] == list(domain.test_clusters)  # both: pay the tolls, drive around


def test_the_reader_takes_show_tests_of_one_kind_only(tmp_path):
    (tmp_path / "sequences.json").write_text(json.dumps({"conditions": {}, "table": {}}))
    show = {"env_id": 1, "kind": "show", "cluster": 0, "share_worse": 0.5}
    (tmp_path / "test_set.json").write_text(json.dumps([show]))
    assert read_teach(tmp_path).test_kind == "show"
    (tmp_path / "test_set.json").write_text(json.dumps([show, {"env_id": 2, "options": []}]))
    with pytest.raises(TeachOutputError, match=r"tests of kind \['choose', 'show'\]; a test set's tests are all of"):
        read_teach(tmp_path)
