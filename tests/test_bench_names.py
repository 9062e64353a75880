"""A benchmark is run as `python bench/NAME.py`, which puts bench/ first on the import path: a file
there named like a module of Python's standard library (selectors, statistics, ...) would be imported
in its place by NumPy, SciPy or asyncio, and every other benchmark would fail at import."""
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "bench"


def test_no_benchmark_shadows_a_standard_module():
    names = sorted(p.stem for p in BENCH.glob("*.py"))
    assert names, "bench/ holds no benchmark"
    assert [n for n in names if n in sys.stdlib_module_names] == []
