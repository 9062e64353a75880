"""A house a newcomer can live in: no two modules import each other (directly or round a loop), no module
is longer than 400 lines without saying why in its docstring, and the functions a newcomer reads first stay
small enough to read (a cyclomatic complexity of at most 10, McCabe's, as ruff's C901 counts it), so that a
new kind of step or page is added in its own module rather than as one more branch there."""
from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGES = ("teaching", "studyapp", "precompute")
MOST_LINES = 400

ROOT = Path(__file__).resolve().parents[1]
MOST = 10
# function -> the module that holds it
READ_FIRST = {
    "step_context": "studyapp/participant/views.py",  # what every participant page is given
    "run_participant": "studyapp/analysis/simulate.py",  # a simulated participant's walk
    "steps_for": "studyapp/participant/flow.py",  # the participant's steps
    "parse_world": "teaching/domains/_grid/worldfile.py",  # what a world file becomes
    "create_study_job": "precompute/study.py",  # a study job from a checked design
}


def too_complex(path: str, most: int) -> dict[str, str]:
    """function name -> ruff's message, for each function of `path` above `most`."""
    proc = subprocess.run([sys.executable, "-m", "ruff", "check", "--isolated", "--select", "C901", "--config",
                           f"lint.mccabe.max-complexity = {most}", "--output-format", "json", path],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode in (0, 1), proc.stderr
    found = json.loads(proc.stdout)
    return {f["message"].split("`")[1]: f["message"] for f in found}


@pytest.mark.parametrize("function, path", READ_FIRST.items())
def test_the_functions_a_newcomer_reads_first_are_small(function, path):
    assert function in (ROOT / path).read_text()
    assert function not in too_complex(path, MOST)


def test_the_count_finds_a_complex_function():
    """The check above is only as good as its count: the flow's recording is known to be above 5."""
    assert "record" in too_complex("studyapp/participant/flow.py", 5)


def _module(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph(root: Path, packages=PACKAGES) -> dict[str, set[str]]:
    """module -> the project's modules it imports, anywhere in its file (a function's import too: a loop
    through one is still a loop a reader must hold in their head)."""
    files = [p for pk in packages for p in sorted((root / pk).rglob("*.py")) if "migrations" not in p.parts]
    modules = {_module(p, root): p for p in files}
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = package.split(".")[:len(package.split(".")) - node.level + 1] if node.level else []
                target = ".".join([*base, *([node.module] if node.module else [])])
                found |= {target, *(f"{target}.{a.name}" for a in node.names)}
            elif isinstance(node, ast.Import):
                found |= {a.name for a in node.names}
        graph[name] = {m for m in found if m in modules and m != name}
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            members = []
            while not members or members[-1] != v:
                members.append(stack.pop())
                on.discard(members[-1])
            if len(members) > 1:
                out.append(sorted(members))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_module_imports_itself_round_a_loop():
    graph = import_graph(ROOT)
    assert len(graph) > 150  # the scan read the project
    assert circles(graph) == []


def test_the_loop_finder_finds_a_loop_through_a_functions_import(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .b import x\n")
    (pkg / "b.py").write_text("def x():\n    from . import c  # noqa\n")
    (pkg / "c.py").write_text("import pkg.a\n")
    (pkg / "d.py").write_text("from .a import y\n")
    assert circles(import_graph(tmp_path, ("pkg",))) == [["pkg.a", "pkg.b", "pkg.c"]]


def test_a_module_longer_than_400_lines_says_why():
    files = [p for pk in PACKAGES for p in (ROOT / pk).rglob("*.py") if "migrations" not in p.parts]
    unexplained = [f"{p.relative_to(ROOT)} ({n} lines)" for p in files
                   if (n := len(p.read_text().splitlines())) > MOST_LINES
                   and f"Longer than {MOST_LINES} lines because" not in (ast.get_docstring(ast.parse(p.read_text()))
                                                                          or "")]
    assert unexplained == []


# studyapp's rooms and the floor each stands on: a room imports only rooms on lower floors, so the
# participant's pages never reach into the researcher's dashboard or the analysis, and the names of
# conditions (studyapp/conditions.py, on the ground floor) serve the analysis, the assignment and the
# designer alike.  Two rooms on one floor do not import each other.
ROOM_FLOORS = {"base": 0, "guards": 1, "participant": 2, "data": 3, "analysis": 3, "researcher": 4,
               "management": 5, "entry": 5}
ROOMS = ("guards", "participant", "data", "analysis", "researcher")
ENTRY = {"studyapp.urls", "studyapp.admin", "studyapp.apps"}


def room_of(module: str) -> str:
    """studyapp.<room>.… -> room; the app's entry points (URLs, admin) -> "entry"; the rest -> "base"."""
    parts = module.split(".")
    if len(parts) > 1 and parts[1] in (*ROOMS, "management"):
        return parts[1]
    return "entry" if module in ENTRY else "base"


def upward_imports(graph: dict[str, set[str]], floors=ROOM_FLOORS) -> list[str]:
    """Each import of a module in another room that does not stand on a lower floor."""
    return sorted(f"{a} -> {b}" for a, targets in graph.items() for b in targets
                  if room_of(a) != room_of(b) and floors[room_of(b)] >= floors[room_of(a)])


def test_studyapp_is_in_rooms_each_importing_only_the_floors_below():
    graph = import_graph(ROOT, ("studyapp",))
    assert len({room_of(m) for m in graph}) == len(ROOM_FLOORS)  # every room has modules
    assert upward_imports(graph) == []
    top = sorted(p.name for p in (ROOT / "studyapp").glob("*.py"))
    assert len(top) <= 12, top  # the ground floor holds what every room shares, not the rooms' own modules


def test_each_room_says_in_one_line_what_it_holds():
    for room in ROOMS:
        doc = ast.get_docstring(ast.parse((ROOT / "studyapp" / room / "__init__.py").read_text()))
        assert doc and "\n" not in doc.strip() and len(doc) > 40, room


def test_the_names_of_conditions_stand_below_the_analysis():
    graph = import_graph(ROOT)
    assert not (ROOT / "studyapp/analysis/conditions.py").exists()
    assert room_of("studyapp.conditions") == "base"
    namers = [m for m, targets in graph.items() if "studyapp.conditions" in targets]
    assert {"studyapp.participant.assignment", "studyapp.researcher.specschema", "precompute.design"} <= set(namers)
    outside = {m for m, targets in graph.items() if any(t.startswith("studyapp.analysis") for t in targets)}
    assert not outside & {"studyapp.participant.assignment", "studyapp.researcher.specschema", "studyapp.models"}


def test_the_floor_check_finds_an_import_that_runs_up():
    graph = {"studyapp.participant.flow": {"studyapp.models", "studyapp.researcher.dashboard"},
             "studyapp.data.exports": {"studyapp.analysis.stats"}, "studyapp.models": set(),
             "studyapp.researcher.dashboard": {"studyapp.participant.flow"}, "studyapp.analysis.stats": set()}
    assert upward_imports(graph) == ["studyapp.data.exports -> studyapp.analysis.stats",
                                     "studyapp.participant.flow -> studyapp.researcher.dashboard"]
