"""The teaching benchmark on Celery workers (``manage.py benchmark``).

Its unit is one selection shared by every learner (a selector, its parameters and a seed; teaching/benchmark/run.py
`batches`): a group of ``precompute.benchmark_cells`` tasks, one per unit, each writing its learners' results to the
results folder, content-addressed.  A worker computes the very bytes the in-process run writes, so the two can be
mixed, and a run stopped at any point is resumed by either: the cells already written are read, not recomputed.
The folder and the table must be on a filesystem every worker sees, as for a table's chunks (docs/scaling.md).
"""
from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from celery import group
from kombu.exceptions import OperationalError
from kombu.utils.url import maybe_sanitize_url

from teaching.api import benchmark_batches, read_benchmark_results

from .canvases import sig
from .jobs import BrokerUnavailable
from .tasks import benchmark_cells, default_queue


def benchmark_group(table_path, cells, out, *, queue=None, app=None):
    """group(one benchmark_cells per shared selection of `cells`) on `queue` (default: settings.PRECOMPUTE_QUEUE),
    through `app` (default: the project's)."""
    queue = queue or default_queue()
    table_path, out = str(Path(table_path).resolve()), str(Path(out).resolve())
    return group([sig(benchmark_cells, table=table_path, out=out, queue=queue, app=app,
                      cells=[{"cell": c.describe(), "key": c.key} for c in batch])
                  for batch in benchmark_batches(cells)], app=app or benchmark_cells.app)


def run_on_workers(table_path, cells, out, *, queue=None, app=None, timeout: float | None = None,
                   progress: Callable[[int, int], None] | None = None, poll: float = 0.5) -> list[dict]:
    """Send `cells` (of the table at `table_path`) to the workers and wait for every one: their results, in
    `cells`' order.  BrokerUnavailable if the group cannot be sent; a task's failure is raised as the task raised
    it; TimeoutError after `timeout` seconds (None: wait for ever).  progress(units done, units)."""
    canvas = benchmark_group(table_path, cells, out, queue=queue, app=app)
    try:
        result = canvas.apply_async()
    except OperationalError as exc:
        url = maybe_sanitize_url(canvas.app.conf.broker_url)
        raise BrokerUnavailable(f"cannot send the benchmark to the broker at {url}: {exc}") from None
    start, total = time.monotonic(), len(canvas.tasks)
    try:
        while not result.ready():
            if result.failed():
                break  # the first failure is raised below, without waiting for the rest
            if progress:
                progress(result.completed_count(), total)
            if timeout is not None and time.monotonic() - start > timeout:
                raise TimeoutError(f"the benchmark's {total - result.completed_count()} of {total} units were "
                                   f"still running after {timeout:.0f} s: is a worker on the queue?")
            time.sleep(poll)
        result.get(propagate=True, disable_sync_subtasks=False)
        if progress:
            progress(total, total)
    finally:
        result.forget()
    return read_benchmark_results(out, cells)
