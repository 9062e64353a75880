"""teaching.api: what the web side and the workers may use, and that teaching stays Django-free.

Under pytest-django every test runs with Django loaded, so "teaching never imports Django" can
only be checked in a fresh interpreter.
"""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import teaching
from teaching import api
from teaching.core.build import code_fingerprint, source_files

ROOT = Path(__file__).resolve().parents[2]

FRESH = """
import sys
import teaching
import teaching.api as api
from teaching.__main__ import main

out = sys.argv[1]
assert main(["build", "--preset", "tiny", "--thetas", "4", "--out", out]) == 0
table = api.TrajectoryTable.load(out)
api.condition_sequence(table, "exact")
django = sorted(m for m in sys.modules if m == "django" or m.startswith("django."))
assert not django, f"teaching imported {django}"
print("django-free")
"""


def test_teaching_and_a_tiny_build_leave_django_out(tmp_path):
    run = subprocess.run([sys.executable, "-c", FRESH, str(tmp_path / "table")], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip().endswith("django-free")


def test_every_exported_name_exists():
    assert sorted(api.__all__) == sorted(set(api.__all__))
    for name in api.__all__:
        assert getattr(api, name) is not None, name


def _teaching_imports(path: Path) -> list[str]:
    """The teaching modules `path` imports ("teaching.api", "teaching.core.table", ...)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "teaching":
                found += [f"teaching.{a.name}" for a in node.names]
            elif node.module.startswith("teaching."):
                found.append(node.module)
        elif isinstance(node, ast.Import):
            found += [a.name for a in node.names if a.name == "teaching" or a.name.startswith("teaching.")]
    return found


def test_web_side_and_workers_import_only_the_api():
    offenders = {}
    for package in ("studyapp", "precompute", "config"):
        for path in sorted((ROOT / package).rglob("*.py")):
            bad = [m for m in _teaching_imports(path) if m != "teaching.api"]
            if bad:
                offenders[str(path.relative_to(ROOT))] = bad
    assert not offenders


def test_code_fingerprint_covers_the_core_and_the_domain(monkeypatch):
    root = Path(teaching.__file__).resolve().parent
    core, driving = root / "core", root / "domains" / "driving"
    names = {p.relative_to(root).as_posix() for p in source_files(core) + source_files(driving)}
    assert {"core/build.py", "core/selection.py", "domains/driving/planner.py", "domains/driving/kernels.py"} <= names
    assert names == {p.relative_to(root).as_posix() for d in (core, driving) for p in d.rglob("*.py")
                     if "__pycache__" not in p.parts and not p.name.startswith(".")}
    assert code_fingerprint("driving") == code_fingerprint(roots=(core, driving))


def test_a_new_module_changes_the_fingerprint(tmp_path):
    (tmp_path / "world.py").write_text("G = 1\n")
    before = code_fingerprint(roots=(tmp_path,))
    assert code_fingerprint(roots=(tmp_path,)) == before  # deterministic
    (tmp_path / "newcomer.py").write_text("")
    added = code_fingerprint(roots=(tmp_path,))
    assert added != before
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "deeper.py").write_text("")
    assert code_fingerprint(roots=(tmp_path,)) != added
    (tmp_path / "__pycache__").mkdir()
    (tmp_path / "__pycache__" / "cached.py").write_text("")
    (tmp_path / ".#lock.py").write_text("")
    assert len(source_files(tmp_path)) == 3  # compiled files and editors' lock files are not modules
