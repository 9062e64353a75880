"""python -m teaching teach --selector: named selectors join the conditions of the teach output (its
sequences.json, the extended ideal-user matrix, the cluster grids, the pilot's predictions), and a bad
name or parameter is one line from the argument parser (exit 2)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from teaching.core.conditions import condition_sequence
from teaching.core.selection import CONDITIONS
from teaching.core.table import TrajectoryTable
from teaching.core.teachout import read_teach
from teaching.teach import main
from tests.conftest import TINY_PRESETS, tiny_preset_table

SELECTORS = {"scot": ("scot", {}), "bec-scaffold:k=2": ("bec-scaffold", {"k": 2}),
             "highlights:k=5": ("highlights", {"k": 5})}


@pytest.fixture(scope="module", params=list(TINY_PRESETS))
def tiny(request, tmp_path_factory):
    return tiny_preset_table(tmp_path_factory, request.param)


def test_named_selectors_join_the_conditions(tiny, tmp_path):
    out = tmp_path / "out"
    argv = ["--table", str(tiny), "--out", str(out), "--no-progress", "--min-option-distance", "0.1", "--seed", "3"]
    assert main([*argv, *(a for label in SELECTORS for a in ("--selector", label))]) in (0, 2)  # 2: no test set
    table = TrajectoryTable.load(tiny)
    ids = np.asarray(table.env_ids)
    conditions = json.loads((out / "sequences.json").read_text())["conditions"]
    assert tuple(conditions) == CONDITIONS + tuple(SELECTORS)
    for label, (name, params) in SELECTORS.items():
        seq = condition_sequence(table, name, seed=3, params=params)[0]
        assert conditions[label]["env_ids"] == ids[seq.envs].tolist()
        assert conditions[label]["p_theta_star"] == seq.p
        assert conditions[label]["selector"] == name and conditions[label]["params"].items() >= params.items()
    scot = len(conditions["scot"]["env_ids"])
    assert scot < len(conditions["bec-scaffold:k=2"]["env_ids"]) <= scot + 2
    assert 1 <= len(conditions["highlights:k=5"]["env_ids"]) <= 5
    assert set(read_teach(out).conditions) == set(conditions)  # what the sheet and a study spec read

    matrix = json.loads((out / "matrix.json").read_text())
    names = matrix["extended_sequence_names"]
    assert names[-3:] == list(SELECTORS)
    rows = np.asarray(matrix["extended_matrix"])
    assert rows.shape == (len(names), len(matrix["user_names"]))
    exact = matrix["user_names"].index("exact")
    for label in SELECTORS:  # every example-based selector reports P(θ*) under exact IRL
        assert rows[names.index(label), exact] == pytest.approx(conditions[label]["p_theta_star"][-1], rel=1e-6)
    grids = json.loads((out / "examples_per_cluster.json").read_text())["grids"]
    for label in SELECTORS:
        assert np.asarray(grids[label]).sum() <= len(conditions[label]["env_ids"])
    tests = json.loads((out / "test_set.json").read_text())
    if isinstance(tests, list):  # the tests keep clear of the added conditions' examples too
        assert not {t["env_id"] for t in tests} & {e for c in conditions.values() for e in c["env_ids"]}


@pytest.mark.parametrize("spec, message", [
    ("nope", "unknown selector 'nope'; choose from"),
    ("bec-scaffold:k=-1", "selector 'bec-scaffold': parameter 'k': must be an integer >= 0, got -1"),
    ("highlights:n=3", "selector 'highlights': unknown parameter 'n'; it takes k"),
    ("scot:k", "selector 'scot': 'k' is not KEY=VALUE"),
    ("exact", "selector 'exact': the teach output already has a sequence of that name"),
])
def test_bad_selectors_are_one_line_with_exit_2(tiny, tmp_path, capsys, spec, message):
    try:
        code = main(["--table", str(tiny), "--out", str(tmp_path / "o"), "--no-progress", "--selector", spec])
    except SystemExit as exc:  # the argument parser's refusal
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err
    assert len([line for line in err.splitlines() if "error" in line]) == 1
