"""No test asserts how long something took.

The suite runs on shared 2-core machines beside other jobs, where any step can take ten times its
usual time: an assertion on elapsed time fails there by the clock, not because the code broke, and a
red main blocks everyone's landing.  A test checks behaviour by events and counts (the chunk stored,
the worker's ready line, the cache's timeouts counted); a timeout may only guard against a hang
(tests/services.py `wait_until`); speed and latency are printed by the benchmarks in bench/.

The check below reads every test module's syntax tree.  A value is *timed* when it comes from a
clock (time.monotonic, perf_counter, time.time, ...), from a helper that returns seconds
(`.total_seconds()`, the load harness's `wait_for_postgres`), from a `.seconds` attribute, or is
computed from a timed value: followed through assignments, `d[key] = ...`, `d.update(key=...)`,
`xs.append(...)` and the module's own functions' return values, over the whole module.  `len(...)`
of a timed list is a count, not a time.  An `assert` that compares a timed value is reported.
"""
from __future__ import annotations

import ast
from pathlib import Path

CLOCKS = {"monotonic", "monotonic_ns", "perf_counter", "perf_counter_ns", "time", "time_ns", "process_time"}
# what returns seconds: datetime's and timeit's, and the load harness's (tests/load/harness.py,
# whose visits carry theirs as `.seconds`)
SECONDS_HELPERS = {"total_seconds", "default_timer", "wait_for_postgres", "restart_postgres"}
SECONDS_ATTRIBUTES = {"seconds"}
COUNTS = {"len"}


def _is_clock(call: ast.Call) -> bool:
    func = call.func
    if isinstance(func, ast.Attribute):
        if isinstance(func.value, ast.Name) and func.value.id == "time" and func.attr in CLOCKS:
            return True
        return func.attr in SECONDS_HELPERS
    return isinstance(func, ast.Name) and func.id in SECONDS_HELPERS | (CLOCKS - {"time"})


class _Timed:
    """The names, string keys and attributes of one module that hold timed values."""

    def __init__(self):
        self.names: set[str] = set()
        self.keys: set[str] = set()
        self.helpers: set[str] = set()  # the module's functions that return seconds

    def holds_time(self, node: ast.AST) -> bool:
        if isinstance(node, ast.Call):
            if isinstance(node.func, ast.Name) and node.func.id in COUNTS:
                return False
            if _is_clock(node) or _called(node) in self.helpers:
                return True
        if isinstance(node, ast.Name):
            return node.id in self.names
        if isinstance(node, ast.Attribute) and node.attr in SECONDS_ATTRIBUTES:
            return True
        if isinstance(node, ast.Subscript) and _key(node) in self.keys:
            return True
        if isinstance(node, ast.Lambda):
            return False
        if isinstance(node, ast.ListComp | ast.SetComp | ast.GeneratorExp | ast.DictComp):
            # the elements and what they are drawn from; a filter on time picks events, it times nothing
            parts = [node.key, node.value] if isinstance(node, ast.DictComp) else [node.elt]
            return any(self.holds_time(part) for part in parts + [g.iter for g in node.generators])
        return any(self.holds_time(child) for child in ast.iter_child_nodes(node))

    def learn(self, tree: ast.Module) -> None:
        """Follow timed values through the module's assignments until nothing new is learnt."""
        while True:
            before = (len(self.names), len(self.keys), len(self.helpers))
            for node in ast.walk(tree):
                if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign) and node.value is not None:
                    if self.holds_time(node.value):
                        for target in getattr(node, "targets", None) or [node.target]:
                            self._mark(target)
                elif isinstance(node, ast.For) and self.holds_time(node.iter):
                    self._mark(node.target)
                elif isinstance(node, ast.NamedExpr) and self.holds_time(node.value):
                    self._mark(node.target)
                elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                      and node.func.attr == "update"):
                    self.keys |= {k.arg for k in node.keywords if k.arg and self.holds_time(k.value)}
                elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                      and node.func.attr == "append" and any(self.holds_time(a) for a in node.args)):
                    self._mark(node.func.value)
                elif (isinstance(node, ast.FunctionDef) and any(
                        r.value is not None and self.holds_time(r.value) for r in _own_returns(node))):
                    self.helpers.add(node.name)
            if (len(self.names), len(self.keys), len(self.helpers)) == before:
                return

    def _mark(self, target: ast.AST) -> None:
        if isinstance(target, ast.Name):
            self.names.add(target.id)
        elif isinstance(target, ast.Subscript) and _key(target) is not None:
            self.keys.add(_key(target))
        elif isinstance(target, ast.Tuple | ast.List):
            for element in target.elts:
                self._mark(element)


def _own_returns(function: ast.FunctionDef):
    """The function's return statements, not those of the functions defined inside it."""
    todo = list(function.body)
    while todo:
        node = todo.pop()
        if isinstance(node, ast.Return):
            yield node
        elif not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda | ast.ClassDef):
            todo.extend(ast.iter_child_nodes(node))


def _called(call: ast.Call) -> str | None:
    func = call.func
    return func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)


def _key(node: ast.Subscript) -> str | None:
    return node.slice.value if isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, str) else None


def timed_assertions(source: str) -> list[int]:
    """The line numbers of the `assert` statements in `source` that compare a timed value."""
    tree = ast.parse(source)
    timed = _Timed()
    timed.learn(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Assert):
            compares = [n for n in ast.walk(node.test) if isinstance(n, ast.Compare)]
            if any(timed.holds_time(part) for c in compares for part in (c.left, *c.comparators)):
                found.append(node.lineno)
    return sorted(found)


HOW_INSTEAD = ("these compare a clock's reading; check an event or a count instead, guard a hang with "
               "tests/services.py wait_until, and print the figure in bench/: ")


def test_no_test_asserts_a_duration():
    root = Path(__file__).resolve().parent
    found = [f"{path.relative_to(root.parent)}:{line}" for path in sorted(root.rglob("*.py"))
             for line in timed_assertions(path.read_text())]
    assert not found, HOW_INSTEAD + ", ".join(found)


def _snippet(text: str) -> str:
    """A test module's source from a case written with CHECK for `assert`: the cases are timed
    assertions on purpose, and spelt out they would read as this suite's own."""
    return text.replace("CHECK ", "assert ")


def test_the_check_finds_each_way_a_duration_was_asserted():
    """The forms this suite once used, each reported; the behaviour checks beside them are not."""
    cases = {
        "took = time.monotonic() - lost_at\nCHECK took < 120 and job.attempts == 2": [2],
        "import time as t\nstart = time.perf_counter()\nx = 1\nseconds = [time.perf_counter() - start]\n"
        "rise = np.percentile(seconds, 95)\nCHECK rise < 0.1": [6],
        "CHECK harness.visit(url, 5).seconds < P95_BAR": [1],
        "waited = (finished - started).total_seconds()\nCHECK 0 < waited < 10": [2],
        "def f():\n    events.update(back_s=time.monotonic() - killed)\nCHECK events['back_s'] <= 10": [3],
        "t0 = time.monotonic()\nCHECK job.status == FAILED and time.monotonic() - t0 < 60": [2],
        "times = []\nfor _ in range(3):\n    times.append(visit(url, 5).seconds)\nCHECK max(times) < 5": [4],
        "CHECK all(g.seconds < 1 for g in gets)": [1],
        "def answer_seconds():\n    s = []\n    s.append(time.perf_counter() - t)\n    return np.array(s)\n"
        "hung = answer_seconds()\nCHECK np.percentile(hung, 95) < 0.1": [6],
        "after = [e for e in events if e['time'] >= killed_at]\nCHECK len(after) == 3 and after[0]['k'] == 1": [],
    }
    for source, lines in cases.items():
        assert timed_assertions(_snippet(source)) == lines, source
    fine = ("start = time.monotonic()\ntimes = [time.monotonic() - start]\nCHECK len(times) == 40\n"
            "CHECK job.status == 'succeeded' and timeouts == 1\nCHECK all(g.answered for g in gets)\n"
            "monkeypatch.setattr(security.time, 'time', lambda: now[0])\nCHECK r['Retry-After'] == '20'\n")
    assert timed_assertions(_snippet(fine)) == []
    helper = "def f(url):\n    t = time.monotonic()\n    return time.monotonic() - t\nCHECK f(url) < 5"
    assert timed_assertions(_snippet(helper)) == [4]
