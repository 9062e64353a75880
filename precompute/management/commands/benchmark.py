"""The teaching benchmark on Celery workers: every selector x every learner x seeds on each table.

    python manage.py benchmark --table var/tables/demo          # into settings.BENCHMARK_DIR
    python manage.py benchmark --table /shared/tables/paper --out /shared/benchmark --queue bench
    python manage.py benchmark --table var/tables/demo --out var/benchmark --in-process

The same cells, the same result files and the same summary as ``python -m teaching benchmark``; here one task per
shared selection goes to the workers (settings' broker: the filesystem on one machine, Redis across machines),
or with --in-process the cells are computed here.  A rerun computes only the cells not yet in --out.  Each table's
leaderboard goes to <out>/tables/<content hash>.json, where a study's dashboard finds the one of its table.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from django.conf import settings
from django.core.management.base import BaseCommand, CommandError
from tqdm import tqdm

from precompute.benchmarking import run_on_workers
from precompute.jobs import BrokerUnavailable
from teaching.api import (
    benchmark_arguments,
    benchmark_plan,
    run_benchmark_cells,
    timed_benchmark,
    write_benchmark_summary,
)


class Command(BaseCommand):
    help = "The teaching benchmark (docs/benchmark.md), its cells computed by Celery workers."

    def add_arguments(self, parser):
        benchmark_arguments(parser, out_default=settings.BENCHMARK_DIR)  # where the dashboards look
        parser.add_argument("--queue", help="Celery queue (default: settings.PRECOMPUTE_QUEUE)")
        parser.add_argument("--in-process", action="store_true", help="compute the cells here, not on workers")
        parser.add_argument("--timeout", type=float, help="give up waiting for the workers after this many seconds")

    def handle(self, *args, **opts):
        options = argparse.Namespace(**opts)
        try:
            planned = benchmark_plan(options)
        except (ValueError, OSError) as exc:
            raise CommandError(str(exc)) from None
        out, done = Path(opts["out"]), []
        stream = getattr(self.stderr, "_out", sys.stderr)
        for path, table, cells in planned:
            where = "here" if opts["in_process"] else "on the workers"
            with tqdm(total=len(cells) if opts["in_process"] else None, file=stream, disable=opts["no_progress"],
                      desc=f"benchmark {table.meta.get('preset')} {where}", unit="cell" if opts["in_process"]
                      else "unit") as bar:
                def progress(n, total, bar=bar):
                    bar.total = total
                    bar.update(n - bar.n)
                def compute(path=path, table=table, cells=cells, progress=progress):
                    if opts["in_process"]:
                        return run_benchmark_cells(table, cells, out, progress=progress)
                    return run_on_workers(path, cells, out, queue=opts["queue"], timeout=opts["timeout"],
                                          progress=progress)
                try:
                    results = timed_benchmark(out, table.meta["content_hash"], cells,
                                              "in one process" if opts["in_process"] else "on Celery workers", compute)
                except (BrokerUnavailable, TimeoutError) as exc:
                    raise CommandError(str(exc)) from None
            done.append((path, table, results))
        self.stdout.write(write_benchmark_summary(out, done, opts["leaderboard"]))
        self.stdout.write(f"wrote {out}/summary.md and {out}/summary.json "
                          f"({sum(len(c) for *_, c in planned):,} cells)")
