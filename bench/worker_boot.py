"""How long a Celery worker takes from its start to "ready.", as supervisord restarts it.

The command is config/supervisord.conf's (prefork, one process, no mingle or gossip, Django's
checks skipped), on the embedded filesystem broker in a scratch VAR_DIR, so no server is needed.
A killed worker is back this long after supervisord notices (the bar: 10 s, on a machine
also serving participants; tests/load/test_supervision.py).

    .venv/bin/python bench/worker_boot.py                       # this checkout, 5 starts
    .venv/bin/python bench/worker_boot.py --code /tmp/old      # side by side with another checkout

--code DIR times DIR's code too, alternating start by start with this checkout's (the machine's
speed drifts).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from precompute import procs  # noqa: E402  (the tests' worker command and readiness wait)


def boot_seconds(code: Path, scratch: Path) -> float:
    """Seconds from the worker's spawn to its "ready." line; the worker is then killed."""
    log = scratch / "worker.log"
    log.unlink(missing_ok=True)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("DJANGO_", "DATABASE_", "CELERY_"))}
    env.update(DJANGO_SETTINGS_MODULE="config.settings", CELERY_SKIP_CHECKS="1", VAR_DIR=str(scratch),
               DEBUG="1", PYTHONUNBUFFERED="1")
    python = code / ".venv/bin/python"
    python = str(python) if python.exists() else sys.executable
    command = procs.worker_command("bench-boot", loglevel="INFO", python=python)
    with open(log, "wb") as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen(command, cwd=code, env=env, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True)
    proc.log_path = log
    try:
        procs.wait_ready(proc, timeout=120, poll=0.005)
        return time.perf_counter() - t0
    finally:
        procs.stop_worker(proc, grace=0)  # SIGKILL to its group at once: nothing of it is kept


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=5, help="starts per checkout (default 5)")
    parser.add_argument("--code", type=Path, help="another checkout to time alternately with this one")
    args = parser.parse_args(argv)
    codes = {"this checkout": ROOT, **({f"--code {args.code}": args.code.resolve()} if args.code else {})}
    times = {name: [] for name in codes}
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(args.starts):
            for name, code in codes.items():
                times[name].append(boot_seconds(code, Path(scratch)))
    print(f"worker start to ready, {args.starts} starts each, {os.cpu_count()} cores")
    for name, ts in times.items():
        print(f"  {name:40s} median {statistics.median(ts):5.2f} s  (min {min(ts):.2f}, max {max(ts):.2f})")
    if len(times) == 2:
        (_, a), (_, b) = times.items()
        print(f"  ratio this / other (medians): {statistics.median(a) / statistics.median(b):.2f}")


if __name__ == "__main__":
    main()
