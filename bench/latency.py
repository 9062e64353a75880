"""Benchmark: what a visitor waits for the home page while attackers press on the production server.

    .venv/bin/python bench/latency.py [--table var/tables/demo] [--scenarios idle,slow-clients,slow-bodies]

scripts/serve.sh (nginx, gunicorn, a Celery worker; PostgreSQL and Redis on this machine) serves
the demo study on a fresh database, as tests/load's harness starts it.  For each scenario the
home page is fetched four times a second from 127.0.0.1 and the latency's p50 / p95 / max printed
beside its bar (p95 under 1 s):

* idle: nothing else;
* slow-clients: 100 connections from one address trickling their requests a byte at a time
  (tests/load/test_slow_clients.py's load);
* slow-bodies: 10,000 slow POST bodies from 300 addresses (tests/load/test_slow_bodies.py's).

The tests check the behaviour (every GET answered, the pressure really on); the figures live
here because a shared 2-core machine can stretch any of them.  The exit status is 0 when every
bar holds.  A worker's restart time is bench/worker_boot.py's.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.load import harness  # noqa: E402
from tests.load.test_slow_bodies import under_slow_bodies  # noqa: E402
from tests.load.test_slow_clients import under_slow_clients  # noqa: E402

P95_BAR_S = 1.0


def idle(server: harness.Server) -> list[harness.Visit]:
    return harness.visits_during(server.base_url + "/", 10.0, timeout=10.0)


SCENARIOS = {"idle": idle, "slow-clients": lambda s: under_slow_clients(s)[0],
             "slow-bodies": lambda s: under_slow_bodies(s)[0]}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--table", type=Path, default=ROOT / "var/tables/demo", help="the demo table (make table)")
    parser.add_argument("--scenarios", default=",".join(SCENARIOS), help="comma-separated, of: " + ", ".join(SCENARIOS))
    args = parser.parse_args(argv)
    names = [n for n in args.scenarios.split(",") if n]
    unknown = [n for n in names if n not in SCENARIOS]
    if unknown:
        parser.error(f"unknown scenario(s) {', '.join(unknown)}; known: {', '.join(SCENARIOS)}")
    if not (args.table / "meta.json").exists():
        parser.error(f"no table at {args.table}: build it with `make table`")
    ok = True
    print(f"home page latency, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the start")
    with tempfile.TemporaryDirectory() as scratch, harness.Server(Path(scratch), demo_table=args.table) as server:
        for name in names:
            visits = SCENARIOS[name](server)
            answered = [v.seconds for v in visits if v.answered]
            p95 = float(np.percentile([v.seconds if v.answered else np.inf for v in visits], 95, method="nearest"))
            holds = p95 < P95_BAR_S
            ok &= holds
            print(f"  {name:<13} {len(answered)}/{len(visits)} answered; {harness.latency_ms(visits)}  "
                  f"bar p95 < {P95_BAR_S:.0f} s: {'pass' if holds else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
