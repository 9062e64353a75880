"""Tests graded by difficulty: the tertiles of the BEC size of the eligible test environments
(teaching.core.testset.difficulty_levels), worked by hand on a 2-feature table, checked on the tiny
tables of both domains, and ungraded test sets unchanged (a fixture recorded before grading existed).

Re-record the fixture (only after a change meant to alter test sets, or a rebuilt tiny table):

    TEST_BUILDS_DIR=DIR python -m tests.teaching.core.test_testset_difficulty
"""
from __future__ import annotations

import functools
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from teaching.core import bec
from teaching.core.build import PRESETS, build_table
from teaching.core.table import TrajectoryTable
from teaching.core.teachout import TeachOutputError, read_teach
from teaching.core.testset import DIFFICULTIES, TestSetError, difficulty_levels, select_test_set
from teaching.teach import main as teach_main
from tests.conftest import TINY_PRESETS, TINY_TEST_SET, tiny_preset_table
from tests.teaching.core.hand_bec_table import hand_bec_table

FIXTURE = Path(__file__).parent / "fixtures" / "tiny_test_sets.json"
SEQUENCES = Path(__file__).parent / "fixtures" / "tiny_sequences.json"  # the conditions' training
SEEDS = (0, 3)


def training(preset: str) -> list[list[int]]:
    return list(json.loads(SEQUENCES.read_text())[preset]["build_sequences"].values())


def ungraded(table: TrajectoryTable, preset: str) -> dict:
    """The test sets of `table` without a difficulty for SEEDS, each the text test_set.json would hold
    (teaching.core.teachout.write_json's format): compared as text, byte for byte."""
    return {"content_hash": table.meta["content_hash"],
            "test_sets": {str(seed): json.dumps(select_test_set(table, training(preset), seed=seed, skip_missing=True,
                                                                **TINY_TEST_SET), indent=1)
                          for seed in SEEDS}}


@pytest.fixture(scope="module", params=list(TINY_PRESETS))
def tiny(request, tmp_path_factory):
    preset = request.param
    path = tiny_preset_table(tmp_path_factory, preset)
    return preset, TrajectoryTable.load(path), path


def test_ungraded_test_sets_are_the_ones_recorded_before_grading(tiny):
    preset, table, _ = tiny
    want = json.loads(FIXTURE.read_text())[preset]
    assert ungraded(table, preset) == want


def test_tertiles_by_hand():
    """hand_bec_table's environments allow the angles E0 [26.57°, 63.43°], E1 [18.43°, 56.31°],
    E2 [33.69°, 90°], E3 [26.57°, 53.13°] of the quarter circle (its docstring): sizes 0.410, 0.421,
    0.626, 0.295.  Sorted, the tertiles fall on the 2nd and 3rd (positions 3/3 and 6/3 of 0..3), so
    q1 = E0's size, q2 = E1's: E3 and E0 (an edge counts as the harder side) are high, E1 medium,
    E2 low."""
    def width(lo, hi):  # tan of the angles -> fraction of π/2
        return (np.arctan(hi) - np.arctan(lo)) / (np.pi / 2)

    want = [width(1 / 2, 2), width(1 / 3, 3 / 2), width(2 / 3, np.inf), width(1 / 2, 4 / 3)]
    size = bec.environment_sizes(hand_bec_table(), np.arange(4))
    np.testing.assert_allclose(size, want, rtol=1e-8)  # normals are rounded (bec.NORMAL_DECIMALS)
    level, (q1, q2) = difficulty_levels(size)
    assert [DIFFICULTIES[v] for v in level] == ["high", "medium", "low", "high"]
    assert (q1, q2) == (size[0], size[1])
    assert [DIFFICULTIES[v] for v in difficulty_levels([0.5, 0.5, 0.5])[0]] == ["high"] * 3  # all on the edge


def test_low_difficulty_tests_have_larger_becs_than_high_ones(tiny):
    preset, table, _ = tiny
    chosen = {d: select_test_set(table, training(preset), seed=0, skip_missing=True, difficulty=d, **TINY_TEST_SET)
              for d in DIFFICULTIES}
    assert chosen["low"] and chosen["high"]
    edges = {tuple(t["bec_tertiles"]) for tests in chosen.values() for t in tests}
    assert len(edges) == 1  # one set of tertiles: over every eligible environment, not per cluster
    (q1, q2), = edges
    for d, tests in chosen.items():
        for t in tests:
            assert t["difficulty"] == d and 0 <= t["bec_size"] <= 1
            assert t["bec_size"] == bec.environment_sizes(table, [t["env_index"]])[0]
            assert {"low": t["bec_size"] > q2, "medium": q1 < t["bec_size"] <= q2, "high": t["bec_size"] <= q1}[d]
    assert min(t["bec_size"] for t in chosen["low"]) > max(t["bec_size"] for t in chosen["high"])


def test_a_cluster_without_an_environment_of_the_difficulty_is_one_line(tiny):
    preset, table, _ = tiny
    with pytest.raises(TestSetError) as info:  # the tiny tables have low tests for one cluster only
        select_test_set(table, training(preset), seed=0, difficulty="low", **TINY_TEST_SET)
    message = str(info.value)
    assert message.startswith("no test environment of low difficulty for cluster '") and "\n" not in message
    with pytest.raises(ValueError, match="unknown test difficulty 'hard'; choose from low, medium, high"):
        select_test_set(table, training(preset), difficulty="hard")


def test_teach_writes_the_asked_difficulty_and_the_reader_reads_it(tiny, tmp_path, capsys):
    _, _, path = tiny
    out = tmp_path / "out"
    argv = ["--table", str(path), "--out", str(out), "--no-progress", "--min-option-distance", "0.1"]
    assert teach_main([*argv, "--test-difficulty", "high"]) in (0, 2)  # 2: a cluster without a high test
    output = read_teach(out)
    if output.tests is None:
        assert "of high difficulty for cluster" in output.no_tests
    else:
        assert output.test_difficulty == "high"
        assert all(t["difficulty"] == "high" and "bec_size" in t for t in output.tests)
    assert teach_main([*argv, "--test-difficulty", "low"]) == 2  # the tiny tables have low tests for one cluster
    err = capsys.readouterr().err
    assert "no test environment of low difficulty for cluster '" in err and "Traceback" not in err
    assert read_teach(out).no_tests.startswith("no test environment of low difficulty")
    with pytest.raises(SystemExit) as info:  # argparse: exit 2, one line naming the choices
        teach_main([*argv, "--test-difficulty", "hard"])
    assert info.value.code == 2 and "invalid choice: 'hard'" in capsys.readouterr().err


def test_the_reader_refuses_tests_of_mixed_difficulty(tmp_path):
    (tmp_path / "sequences.json").write_text(json.dumps({"conditions": {}, "table": {}}))
    tests = [{"env_id": 1, "difficulty": "low", "options": []}, {"env_id": 2, "difficulty": "high", "options": []}]
    (tmp_path / "test_set.json").write_text(json.dumps(tests))
    with pytest.raises(TeachOutputError, match="a test set is graded at one of low, medium, high or not at all"):
        read_teach(tmp_path)
    (tmp_path / "test_set.json").write_text(json.dumps(tests[:1]))
    assert read_teach(tmp_path).test_difficulty == "low"


def main() -> int:
    from tests.builds import built_in  # noqa: PLC0415

    root = Path(os.environ["TEST_BUILDS_DIR"])
    out = {preset: ungraded(TrajectoryTable.load(built_in(root, name, functools.partial(build_table, PRESETS[preset]))),
                            preset)
           for preset, name in TINY_PRESETS.items()}
    FIXTURE.write_text(json.dumps(out, indent=1, sort_keys=True) + "\n")
    print(f"recorded {FIXTURE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
