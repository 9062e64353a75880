"""The suite's order (tests/conftest.py pytest_collection_modifyitems): the longest modules of the last
profiled run first, each module's tests together and in their own order; and the script that writes the
durations reads a pytest --durations=0 log."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from scripts.module_durations import module_seconds
from tests import conftest


def test_modules_run_longest_first_each_in_one_piece(monkeypatch):
    monkeypatch.setattr(conftest, "DURATIONS", {"tests/long.py": 90, "tests/mid.py": 30})
    collected = ["tests/new.py::a", "tests/mid.py::a", "tests/long.py::a", "tests/mid.py::b", "tests/long.py::b[1]",
                 "tests/other.py::a", "tests/long.py::b[2]"]
    items = [SimpleNamespace(nodeid=n) for n in collected]
    conftest.pytest_collection_modifyitems(items)
    assert [i.nodeid for i in items] == ["tests/long.py::a", "tests/long.py::b[1]", "tests/long.py::b[2]",
                                         "tests/mid.py::a", "tests/mid.py::b", "tests/new.py::a", "tests/other.py::a"]


def test_the_durations_file_names_this_suites_modules():
    root = Path(__file__).resolve().parent
    assert len(conftest.DURATIONS) > 100
    assert all(name.startswith("tests/") and name.endswith(".py") for name in conftest.DURATIONS)
    modules = {p.relative_to(root.parent).as_posix() for p in root.rglob("test_*.py")}
    assert len(set(conftest.DURATIONS) & modules) > 0.8 * len(conftest.DURATIONS)


def test_the_durations_are_read_from_a_pytest_log():
    log = ["============ slowest durations ============",
           "12.50s call     tests/a/test_x.py::test_one[1]",
           "0.40s setup    tests/a/test_x.py::test_one[1]",
           "3.10s call     tests/b/test_y.py::Test::test_two",
           "(14 durations < 0.005s hidden.  Use -vv to show these durations.)"]
    assert module_seconds(log) == {"tests/a/test_x.py": 13, "tests/b/test_y.py": 3}
