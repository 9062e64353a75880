"""The teaching benchmark on Celery workers (precompute/benchmarking.py, ``manage.py benchmark``): a real
`celery worker` on Redis writes every cell's result with the bytes the in-process run writes; the command's
in-process path gives the summary ``python -m teaching benchmark`` gives; a worker refuses a table that changed
since the cells were planned."""
from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys
import uuid
from pathlib import Path

import pytest
from django.core.management import call_command

from precompute import procs
from precompute.benchmarking import benchmark_group, run_on_workers
from teaching.api import TrajectoryTable, plan_benchmark, run_benchmark_cells
from teaching.benchmark.run import run_batch
from tests.precompute.test_precompute_real_worker import client_app, log_tail, worker_env

ROOT = Path(__file__).resolve().parents[2]


def result_bytes(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "cells").glob("*.json"))}


@pytest.mark.slow
@pytest.mark.redis
def test_the_workers_write_the_in_process_runs_bytes(redis_url, gridworld_tiny_table, tmp_path):
    table = TrajectoryTable.load(gridworld_tiny_table)
    cells = plan_benchmark(table.meta["content_hash"], seeds=2)  # every selector x every learner: 240 cells
    run_benchmark_cells(table, cells, tmp_path / "here")

    queue, app = f"benchmark-test-{uuid.uuid4().hex[:8]}", client_app(redis_url)
    units = benchmark_group(gridworld_tiny_table, cells, tmp_path / "workers", queue=queue, app=app).tasks
    assert len(units) == len(cells) // 8  # one per shared selection: its 8 learners' cells
    worker = procs.start_worker(queue, concurrency=2, env=worker_env(redis_url, tmp_path),
                                log_path=tmp_path / "worker.log")
    try:
        procs.wait_ready(worker, timeout=90)
        seen = []
        try:
            results = run_on_workers(gridworld_tiny_table, cells, tmp_path / "workers", queue=queue, app=app,
                                     timeout=300, progress=lambda n, total: seen.append((n, total)))
        except Exception as exc:
            pytest.fail(f"{type(exc).__name__}: {exc}\nworker log:\n{log_tail(worker)}")
    finally:
        procs.stop_worker(worker)
    here, workers = result_bytes(tmp_path / "here"), result_bytes(tmp_path / "workers")
    assert len(here) == len(cells) and workers == here
    assert [r["key"] for r in results] == [c.key for c in cells]
    assert seen[-1] == (len(units), len(units))
    assert "benchmark_cells" in log_tail(worker) and "succeeded" in log_tail(worker)


def test_the_commands_in_process_run_gives_the_teaching_commands_summary(gridworld_tiny_table, tmp_path):
    args = ["--table", str(gridworld_tiny_table), "--seeds", "2", "--selector", "scot", "--selector", "random",
            "--learner", "exact", "--learner", "det-euclidean", "--no-progress"]
    subprocess.run([sys.executable, "-m", "teaching", "benchmark", *args, "--out", str(tmp_path / "core")],
                   cwd=ROOT, check=True, capture_output=True, timeout=300)
    call_command("benchmark", *args, "--out", str(tmp_path / "platform"), "--in-process", stdout=io.StringIO())
    assert result_bytes(tmp_path / "platform") == result_bytes(tmp_path / "core")
    assert summary_without_costs(tmp_path / "platform") == summary_without_costs(tmp_path / "core")


def summary_without_costs(out: Path) -> dict:
    """summary.json with each row's selection seconds left out: a measurement, not a result."""
    rows = json.loads((out / "summary.json").read_text())
    return {Path(t).name: [{k: v for k, v in r.items() if k != "selection_cost"} for r in found]
            for t, found in rows.items()}


def test_a_worker_refuses_a_table_that_changed_since_the_cells_were_planned(gridworld_tiny_table, tmp_path):
    [cell] = plan_benchmark("a-table-no-longer-there", selectors=["scot"], learners=["exact"], seeds=1)
    with pytest.raises(ValueError, match="changed since the benchmark was planned"):
        run_batch(gridworld_tiny_table, [{"cell": cell.describe(), "key": cell.key}], tmp_path)
    other = tmp_path / "copy"
    shutil.copytree(gridworld_tiny_table, other)
    message = {"cell": {**cell.describe(), "seed": 1}, "key": cell.key}  # a worker on other code would read this
    with pytest.raises(ValueError, match="reads back as"):
        run_batch(other, [message], tmp_path)
    assert not (tmp_path / "cells").exists()
    assert json.loads((other / "meta.json").read_text())["content_hash"] != cell.table
