"""The teach output on disk: the one writer and the one reader of what ``python -m teaching teach`` writes.

    sequences.json             every condition's environment ids (and P(θ*) curve, chosen τ/λ, sweeps),
                               with the table it was selected on: {"table": {"path", "content_hash", ...}}
    test_set.json              the tests and their 4 options, or {"error": why there is no test set}; tests
                               graded by difficulty (teach --test-difficulty) also hold difficulty,
                               bec_size and bec_tertiles (teaching.core.testset); "show the way" tests
                               (teach --tests show) hold "kind": "show" and no options
                               (teaching.core.showtests); all tests of one output are of one kind
    matrix.json                the ideal-user matrix (a study's simulated pilot reads it)
    examples_per_cluster.json  the cluster grids

The contact sheet (``teaching.core.sheet``) and a study spec (``studyapp.researcher.studies.spec_from_teach``) both
read it through :func:`read_teach`, so a malformed output gives the same one-line error everywhere.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .difficulty import DIFFICULTIES
from .showtests import SHOW, is_show

# What a test asks: choose among 4 options (a test without "kind"), or show the way.
TEST_KINDS = ("choose", SHOW)


class TeachOutputError(ValueError):
    """A teach output that is missing, unreadable or malformed: one line, saying which file and why."""


@dataclass(frozen=True)
class TeachOutput:
    dir: Path
    conditions: dict[str, list[int]]  # name -> environment ids, in showing order
    tests: list[dict] | None  # test_set.json's tests; None when it holds an error
    no_tests: str | None  # why there is no test set (test_set.json's error), or None
    table_path: str  # the table it was selected on, as teach was given it
    table_hash: str | None  # that table's content hash
    test_difficulty: str | None = None  # every test's difficulty (one of DIFFICULTIES), None if ungraded
    test_kind: str | None = None  # what every test asks (one of TEST_KINDS), None when there are no tests

    def matrix(self) -> dict | None:
        """matrix.json, where there is one: read only by who needs it (a study's pilot, not the sheet)."""
        path = self.dir / "matrix.json"
        return _read_json(path) if path.exists() else None


def write_json(path: Path, obj) -> None:
    """One file of the output (NumPy scalars and arrays written as plain JSON numbers and lists)."""
    Path(path).write_text(json.dumps(obj, indent=1, default=_np_default))


def _np_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o).__name__)


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise TeachOutputError(f"no teach output at {path.parent}: {path.name} is missing (run python -m "
                               f"teaching teach --table TABLE --out {path.parent})") from None
    except (OSError, ValueError) as exc:
        raise TeachOutputError(f"{path} is unreadable or not valid JSON: {exc}") from None


def read_teach(teach_dir) -> TeachOutput:
    """Read the teach output in `teach_dir` (or the directory of the sequences.json it names).
    Raises TeachOutputError, one line, for a missing, unreadable or malformed output."""
    teach_dir = Path(teach_dir)
    if teach_dir.is_file():
        teach_dir = teach_dir.parent
    sequences = _read_json(teach_dir / "sequences.json")
    if not (isinstance(sequences, dict) and isinstance(sequences.get("conditions"), dict)
            and isinstance(sequences.get("table", {}), dict)):
        raise TeachOutputError(f"{teach_dir / 'sequences.json'} is not an output of `python -m teaching teach` "
                               "(no 'conditions')")
    conditions = {}
    for name, c in sequences["conditions"].items():
        try:
            conditions[str(name)] = [int(e) for e in c["env_ids"]]
        except (TypeError, KeyError, ValueError):
            raise TeachOutputError(f"{teach_dir / 'sequences.json'}: condition {name!r} has no list of "
                                   "'env_ids'") from None
    tests = _read_json(teach_dir / "test_set.json")
    no_tests = None
    if isinstance(tests, dict) and "error" in tests:
        tests, no_tests = None, str(tests["error"])
    elif not isinstance(tests, list):
        raise TeachOutputError(f"{teach_dir / 'test_set.json'} is neither a list of tests nor an error")
    table = sequences.get("table") or {}
    return TeachOutput(teach_dir, conditions, tests, no_tests, str(table.get("path", "")), table.get("content_hash"),
                       _difficulty(tests, teach_dir / "test_set.json"), _kind(tests, teach_dir / "test_set.json"))


def _difficulty(tests: list | None, path: Path) -> str | None:
    """The difficulty all ``tests`` were drawn at (None: ungraded, or no tests); TeachOutputError if
    they disagree or name an unknown one."""
    found = {t.get("difficulty") if isinstance(t, dict) else None for t in tests or []}
    if len(found) > 1 or not found <= {None, *DIFFICULTIES}:
        raise TeachOutputError(f"{path}: tests of {sorted(map(str, found))} difficulty; a test set is graded at one "
                               f"of {', '.join(DIFFICULTIES)} or not at all")
    return found.pop() if found else None


def _kind(tests: list | None, path: Path) -> str | None:
    """What all ``tests`` ask (None: no tests); TeachOutputError if they are of several kinds or an
    unknown one."""
    found = {t.get("kind", "choose") if isinstance(t, dict) else None for t in tests or []}
    if len(found) > 1 or not found <= set(TEST_KINDS):
        raise TeachOutputError(f"{path}: tests of kind {sorted(map(str, found))}; a test set's tests are all of "
                               f"one of {', '.join(TEST_KINDS)}")
    return found.pop() if found else None


def check_against(output: TeachOutput, table) -> None:
    """Was `output` made from `table` (a TrajectoryTable), and does everything it names lie in it?
    Raises TeachOutputError, one line, otherwise."""
    ours = table.meta.get("content_hash")
    if output.table_hash and output.table_hash != ours:
        raise TeachOutputError(f"teach output at {output.dir} was made from another table (content hash "
                               f"{output.table_hash[:16]} != {str(ours)[:16]}, the table's)")
    known = {int(e) for e in np.asarray(table.env_ids)}
    for name, ids in output.conditions.items():
        missing = [e for e in ids if e not in known]
        if missing:
            raise TeachOutputError(f"condition {name!r} shows environments not in the table: {missing[:5]}")
    try:
        for t in output.tests or []:
            if int(t["env_id"]) not in known:
                raise ValueError
            if is_show(t):  # the participant moves the robot: no options to check
                continue
            if len(t["options"]) != 4:
                raise ValueError
            if any(not 0 <= int(o["theta_index"]) < table.n_thetas or not np.isfinite(float(o.get("regret", 0)))
                   for o in t["options"]):
                raise ValueError
    except (TypeError, KeyError, ValueError):
        raise TeachOutputError(f"{output.dir / 'test_set.json'} does not match the table (an environment it tests "
                               "is not in the table, or a choice test's options are not 4 θ indices of it)") from None
