"""Tests graded by difficulty: the tertiles of the exact BEC size of the eligible test environments
(teaching.core.difficulty), worked by hand on a 2-feature table, checked on the tiny tables of both
domains, and ungraded test sets unchanged (a fixture recorded before grading existed).

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

from teaching.core.build import PRESETS, build_table
from teaching.core.difficulty import DIFFICULTIES, difficulty_levels, environment_sizes, slice_size
from teaching.core.table import TrajectoryTable
from teaching.core.teachout import TeachOutputError, read_teach
from teaching.core.testset import TestSetError, select_test_set
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
    E2 [33.69°, 90°], E3 [26.57°, 53.13°] of the quarter circle (its docstring).  On the simplex
    u = (s, 1 - s) the angle a is s = 1 / (1 + tan a), so the sizes are the segments' lengths
    1/(1 + tan lo) - 1/(1 + tan hi): 0.3333, 0.3500, 0.6000, 0.2381.  Sorted, the tertiles fall on the
    2nd and 3rd (positions 3/3 and 6/3 of 0..3), so q1 = E0's size, q2 = E1's: E3 and E0 (an edge
    counts as the harder side) are high, E1 medium, E2 low."""
    def length(lo, hi):  # tan of the angles -> length of the segment of the simplex
        return 1 / (1 + lo) - 1 / (1 + hi)

    want = [length(1 / 2, 2), length(1 / 3, 3 / 2), length(2 / 3, np.inf), length(1 / 2, 4 / 3)]
    size = environment_sizes(hand_bec_table(), np.arange(4))
    np.testing.assert_allclose(size, want, rtol=1e-9)
    level, (q1, q2) = difficulty_levels(size)
    assert [DIFFICULTIES[v] for v in level] == ["high", "medium", "low", "high"]
    assert (q1, q2) == (size[0], size[1])
    assert [DIFFICULTIES[v] for v in difficulty_levels([0.5, 0.5, 0.5])[0]] == ["high"] * 3  # all on the edge


def test_the_exact_size_of_a_region_in_three_features_by_hand():
    # u1 ≥ u2 and u1 ≥ u3 on the simplex: the third of the triangle nearest the first corner; and u2 ≥ 0.6
    # alone (the constraint 0.4 u2 - 0.6 (u1 + u3) ≥ 0): the corner triangle of side 0.4, 0.16 of the whole
    third = [[1, -1, 0], [1, 0, -1]]
    corner = [[-0.6, 0.4, -0.6]]
    for rows, want in ((third, 1 / 3), (corner, 0.16)):
        normals = np.array(rows, np.float64)
        assert slice_size(normals / np.linalg.norm(normals, axis=1, keepdims=True)) == pytest.approx(want, rel=1e-9)


def test_graded_tests_lie_on_their_side_of_the_tertiles_they_were_graded_by(tiny):
    preset, table, _ = tiny
    chosen = {d: select_test_set(table, training(preset), seed=0, skip_missing=True, difficulty=d, **TINY_TEST_SET)
              for d in DIFFICULTIES}
    assert chosen["low"] and chosen["high"]
    for d, tests in chosen.items():
        for t in tests:
            q1, q2 = t["bec_tertiles"]
            assert t["difficulty"] == d and 0 <= t["bec_size"] <= 1 and t["graded"] in ("all", "cluster")
            assert t["bec_size"] == environment_sizes(table, [t["env_index"]])[0]
            assert {"low": t["bec_size"] > q2, "medium": q1 < t["bec_size"] <= q2, "high": t["bec_size"] <= q1}[d]
    # graded against every cluster, one set of tertiles, and a low test's BEC larger than a high one's
    pooled = {tuple(t["bec_tertiles"]) for tests in chosen.values() for t in tests if t["graded"] == "all"}
    assert len(pooled) <= 1
    low = [t["bec_size"] for t in chosen["low"] if t["graded"] == "all"]
    high = [t["bec_size"] for t in chosen["high"] if t["graded"] == "all"]
    assert not (low and high) or min(low) > max(high)


def test_a_cluster_without_an_environment_of_the_difficulty_says_how_many_each_level_has(tiny):
    preset, table, _ = tiny
    for difficulty in DIFFICULTIES:
        try:
            select_test_set(table, training(preset), seed=0, difficulty=difficulty, **TINY_TEST_SET)
        except TestSetError as exc:
            message = str(exc)
            assert message.startswith(f"no test environment of {difficulty} difficulty for cluster '")
            assert "\n" not in message and ("against its own" in message or "whatever the difficulty" in message)
    with pytest.raises(ValueError, match="unknown test difficulty 'hard'; choose from low, medium, high"):
        select_test_set(table, training(preset), difficulty="hard")


def test_teach_writes_the_asked_difficulty_and_the_reader_reads_it(tiny, tmp_path, capsys):
    _, _, path = tiny
    out = tmp_path / "out"
    argv = ["--table", str(path), "--out", str(out), "--no-progress", "--min-option-distance", "0.1"]
    for difficulty in DIFFICULTIES:
        code = teach_main([*argv, "--test-difficulty", difficulty])
        assert code in (0, 2)  # 2: a cluster without a test of that difficulty
        printed = capsys.readouterr()
        output = read_teach(out)
        if output.tests is None:
            assert f"of {difficulty} difficulty for cluster" in output.no_tests and "Traceback" not in printed.err
        else:
            assert output.test_difficulty == difficulty
            assert all(t["difficulty"] == difficulty and "bec_size" in t for t in output.tests)
            # one line a test: its level, its exact size and the tertiles it was graded by
            lines = [line for line in printed.out.splitlines() if line.startswith("test ")]
            assert len(lines) == len(output.tests) and all("standard error 0 (exact sizes)" in x for x in lines)
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
