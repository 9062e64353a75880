"""bench/teaching_benchmark.py's generated section of docs/benchmarks.md: the bar's verdict is computed from the
figures (met within 600 s in all, not met past it), and the per-cell figure is the table's time over its cells;
bench/teaching_benchmark_workers.py run for real on a tiny table."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from bench import teaching_benchmark as bench
from teaching.benchmark.cells import plan_cells
from teaching.benchmark.run import run_cells
from teaching.core.table import TrajectoryTable

ROOT = Path(__file__).resolve().parents[1]


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


@pytest.mark.slow
def test_the_workers_bench_runs_the_command_on_a_real_worker_with_no_server(gridworld_tiny_table, tmp_path):
    """bench/teaching_benchmark_workers.py on the embedded default (the filesystem broker, a file result backend):
    the command's cells, written by a real `celery worker`, are the in-process run's bytes, and its run record
    says who computed them."""
    tables = tmp_path / "tables"
    tables.mkdir()
    (tables / "gridworld-tiny").symlink_to(gridworld_tiny_table)
    out = tmp_path / "workers"
    subprocess.run([sys.executable, "bench/teaching_benchmark_workers.py", "--preset", "gridworld-tiny",
                    "--tables-dir", str(tables), "--seeds", "1", "--out", str(out), "--selector", "scot",
                    "--selector", "random-uniform"],
                   cwd=ROOT, check=True, capture_output=True, timeout=600)
    table = TrajectoryTable.load(gridworld_tiny_table)
    run_cells(table, plan_cells(table.meta["content_hash"], selectors=["scot", "random-uniform"], seeds=1),
              tmp_path / "here")
    here = {p.name: p.read_bytes() for p in (tmp_path / "here" / "cells").glob("*.json")}
    assert here and {p.name: p.read_bytes() for p in (out / "cells").glob("*.json")} == here
    run = json.loads((out / "runs" / f"{table.meta['content_hash']}.json").read_text())
    assert run["runner"] == "on Celery workers" and run["computed"] == run["cells"] == len(here)
