"""The selector registry: the study's conditions are registry entries whose outputs are the ones
recorded before the registry existed (a fixture of the tiny tables of both domains), and bad names
or parameters get one-line errors naming them.

Re-record the fixture (only after a change meant to alter selection, or a rebuilt tiny table):

    TEST_BUILDS_DIR=DIR python -m tests.teaching.core.test_selector_registry
"""
from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from teaching.core.build import PRESETS, build_table
from teaching.core.conditions import build_sequences, condition_sequence, teach
from teaching.core.selection import ALL_CONDITIONS, CONDITIONS
from teaching.core.selectors import check_params, get_selector, selector_names
from teaching.core.table import TrajectoryTable
from tests.conftest import TINY_PRESETS, tiny_preset_table

FIXTURE = Path(__file__).parent / "fixtures" / "tiny_sequences.json"
SEED = 3


def recorded(table: TrajectoryTable) -> dict:
    """Everything selection produces on `table` that a study or the teach output reads: the
    conditions' environment ids, and every sequence's rows, P(θ*) curve (float.hex: byte for byte)
    and coverage additions."""
    result = teach(table, seed=SEED)
    return {"content_hash": table.meta["content_hash"],
            "build_sequences": build_sequences(table, seed=SEED),
            "sequences": {name: {"envs": s.envs, "p": [float(p).hex() for p in s.p],
                                 "added_for_coverage": s.added_for_coverage}
                          for name, s in sorted(result.sequences.items())},
            "models": {name: str(m) for name, m in sorted(result.models.items())}}


@pytest.fixture(scope="module", params=list(TINY_PRESETS))
def tiny(request, tmp_path_factory):
    return request.param, TrajectoryTable.load(tiny_preset_table(tmp_path_factory, request.param))


def test_the_conditions_give_the_outputs_recorded_before_the_registry(tiny):
    preset, table = tiny
    want = json.loads(FIXTURE.read_text())[preset]
    got = json.loads(json.dumps(recorded(table)))  # tuples -> lists, int keys as the file has them
    assert got["content_hash"] == want["content_hash"], (
        f"the {preset} table changed, so its recorded selections no longer apply; re-record (module docstring)")
    assert got == want


def test_each_condition_alone_equals_the_recorded_whole(tiny):
    preset, table = tiny
    want = json.loads(FIXTURE.read_text())[preset]["sequences"]
    for name in ALL_CONDITIONS:
        seq = condition_sequence(table, name, seed=SEED)[0]
        assert [seq.envs, [float(p).hex() for p in seq.p]] == [want[name]["envs"], want[name]["p"]], name


def test_every_condition_is_a_registered_selector():
    assert set(ALL_CONDITIONS) <= set(selector_names())
    assert set(CONDITIONS) <= set(selector_names())
    assert check_params("coverage-approx*") == {"model": "det-euclidean"}
    assert check_params("exact") == {}


def test_the_registry_holds_every_built_in_selector_whichever_module_was_imported():
    # a fresh interpreter that imports the registry alone: its first lookup registers the rest
    code = "from teaching.core.selectors import selector_names; print(' '.join(selector_names()))"
    names = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert names == list(selector_names())
    assert {"scot", "bec-scaffold", "highlights", *ALL_CONDITIONS} <= set(names)


@pytest.mark.parametrize("call, message", [
    (lambda: get_selector("nope"), "unknown selector 'nope'; choose from exact, "),
    (lambda: check_params("nope"), "unknown selector 'nope'"),
    (lambda: check_params("exact", {"k": 2}), "selector 'exact': unknown parameter 'k'; it takes no parameters"),
    (lambda: check_params("coverage-random", {"model": "nope"}),
     "selector 'coverage-random': parameter 'model': unknown learner model 'nope'"),
    (lambda: check_params("coverage-approx*", {"modle": "exact"}),
     "selector 'coverage-approx*': unknown parameter 'modle'; it takes model"),
])
def test_bad_names_and_parameters_get_one_line_errors(call, message):
    with pytest.raises(ValueError) as info:
        call()
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


def main() -> int:
    root = Path(os.environ["TEST_BUILDS_DIR"])
    out = {}
    for preset, name in TINY_PRESETS.items():
        from tests.builds import built_in  # noqa: PLC0415

        path = built_in(root, name, functools.partial(build_table, PRESETS[preset]))
        out[preset] = recorded(TrajectoryTable.load(path))
    FIXTURE.write_text(json.dumps(out, indent=1, sort_keys=True) + "\n")
    print(f"recorded {FIXTURE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
