"""bench/teaching_benchmark.py's generated section of docs/benchmarks.md: the bar's verdict is computed from the
figures (met within 600 s in all, not met past it), and the per-cell figure is the table's time over its cells."""
from __future__ import annotations

from bench import teaching_benchmark as bench


def figures(seconds: list[float]) -> dict:
    return {"command": "python bench/teaching_benchmark.py", "date": "2026-01-01 00:00", "cores": 2,
            "load_average_start": 0.5, "seeds": 10,
            "tables": [{"preset": f"t{k}", "content_hash": "h", "cells": 1000, "envs": 1200, "thetas": 200,
                        "seconds": s, "cpu_seconds": s} for k, s in enumerate(seconds)]}


def test_the_bar_is_met_or_not_from_the_figures():
    met = bench.markdown(figures([100.0, 200.0]))
    assert "| `t0` | 1,200 × 200 | 1,000 | **100.0 s** | 100.0 ms | 100.0 s |" in met
    assert "| all 2 | | 2,000 | **300.0 s** |" in met and "within 600 s: **met** (300 s)" in met
    assert "**not met** (700 s)" in bench.markdown(figures([400.0, 300.0]))
    assert met.startswith(bench.BEGIN) and met.endswith(bench.END)
