"""Benchmark: the teaching benchmark of one table on Celery workers (`manage.py benchmark`), as one machine runs it
with no extra server: kombu's filesystem broker, Celery's file result backend, one `celery worker` with -c CORES.

    .venv/bin/python bench/teaching_benchmark_workers.py [--preset paper] [--seeds 10] [--out var/leaderboard]
        [--tables-dir var/tables] [--concurrency 2] [--selector NAME ...]

The table is built first where missing, not timed.  The worker starts (not timed), then the command runs every
selector x every learner x the seeds of the table on it, into --out (cells already there are read, not computed):
its wall time, and the run record it leaves in --out/runs/ (which the leaderboard quotes), are the figures.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from precompute import procs  # noqa: E402  (the worker's start and stop, shared with the tests)


def embedded_env(scratch: Path) -> dict:
    """One machine, no server: the filesystem broker under `scratch` and the file result backend."""
    (scratch / "results").mkdir(parents=True, exist_ok=True)
    return {"VAR_DIR": str(scratch / "var"), "CELERY_BROKER_URL": "filesystem://",
            "CELERY_RESULT_BACKEND": f"file://{scratch / 'results'}", "CELERY_SKIP_CHECKS": "1",
            "DATABASE_URL": f"sqlite:///{scratch / 'worker.sqlite3'}", "PYTHONUNBUFFERED": "1",
            "DEBUG": os.environ.get("DEBUG", "1")}  # a local run, as `make demo` is, unless told otherwise


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="paper")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--selector", action="append", metavar="NAME", help="only this selector (repeatable)")
    ap.add_argument("--out", type=Path, default=ROOT / "var" / "leaderboard")
    ap.add_argument("--tables-dir", type=Path, default=ROOT / "var" / "tables")
    ap.add_argument("--concurrency", type=int, default=os.cpu_count() or 1, help="the worker's processes")
    ap.add_argument("--timeout", type=float, default=6 * 3600, help="give up after this many seconds")
    args = ap.parse_args()
    table = args.tables_dir / args.preset
    if not (table / "meta.json").exists():  # not timed
        print(f"building {args.preset} -> {table}")
        subprocess.run([sys.executable, "-m", "teaching", "build", "--preset", args.preset, "--out", str(table)],
                       cwd=ROOT, check=True)
    content_hash = json.loads((table / "meta.json").read_text())["content_hash"]
    queue = f"benchmark-{uuid.uuid4().hex[:8]}"
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, **embedded_env(Path(tmp))}
        worker = procs.start_worker(queue, concurrency=args.concurrency, env=env, log_path=Path(tmp) / "worker.log")
        try:
            procs.wait_ready(worker, timeout=120)
            start = time.perf_counter()
            said = subprocess.run([sys.executable, "manage.py", "benchmark", "--table", str(table), "--out",
                                   str(args.out), "--seeds", str(args.seeds), "--queue", queue, "--no-progress",
                                   "--timeout", str(args.timeout),
                                   *[a for name in args.selector or [] for a in ("--selector", name)]],
                                  cwd=ROOT, env=env, capture_output=True, text=True)
            seconds = time.perf_counter() - start
        finally:
            procs.stop_worker(worker)
        if said.returncode != 0:
            tail = (Path(tmp) / "worker.log").read_text()[-3000:]
            raise SystemExit(f"manage.py benchmark failed:\n{said.stdout[-2000:]}{said.stderr[-2000:]}\n"
                             f"worker log:\n{tail}")
    record = args.out / "runs" / f"{content_hash}.json"
    run = json.loads(record.read_text()) if record.exists() else None
    print(f"{args.preset}: the command took {seconds:.1f} s with a worker of {args.concurrency} processes")
    if run:
        print(f"run record ({record}): {run['computed']:,} of {run['cells']:,} cells computed {run['runner']} "
              f"in {run['seconds']:.1f} s on {run['cores']} cores ({run['date']})")


if __name__ == "__main__":
    main()
