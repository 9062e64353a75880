"""Launch-day load test against the production configuration, with PostgreSQL restarted mid-run.

    python -m tests.load.run --participants 500 --window 60      # or: make load

Creates a fresh PostgreSQL database, serves it with scripts/serve.sh (gunicorn + Celery worker,
Redis cache) on a free loopback port, lets the simulated participants (tests/load/client.py)
go through the whole study, restarts PostgreSQL in the middle (--fault-at; --no-fault to skip),
then prints requests/s, latency percentiles per endpoint and errors by kind, and checks the
database: every acknowledged answer stored exactly once, one condition per participant,
condition counts within 1.  Exit status 0 only when the bars hold:
p95 <= 300 ms for answer posts, no answer lost or duplicated.  Stops by itself: every request is
bounded in time and retries, and the database is dropped afterwards.
"""
from __future__ import annotations

import argparse
import asyncio
import os
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

from . import client, harness

P95_ANSWER_BAR_MS = 300
FAULT_GRACE = 2.0  # seconds after PostgreSQL is back in which a request begun during the outage may still fail


def percentile(values, q):
    """The q-th percentile as one of the measured values (no interpolation); NaN when none."""
    return float(np.percentile(values, q, method="nearest")) if len(values) else float("nan")


def run_load(participants=100, window=20.0, pace=0.05, fault_at=None, workdir=None, workers=None, threads=None,
             seed=0, demo_table=None, study_script=None, env=None, inspect=None) -> dict:
    """Run the whole test; returns the figures and the database checks (see summarise).
    demo_table: the table the demo study is built on (default $DEMO_TABLE or var/tables/demo).
    study_script, env: another study and environment for the server (harness.Server); inspect(server): a
    dict of what else to read off the running server and its database, kept as result["inspected"]."""
    cluster = None
    if fault_at is not None:
        cluster = harness.local_cluster()
        if cluster is None:
            raise RuntimeError("--fault-at needs the PostgreSQL cluster serving "
                               f"{harness.PG_URL} on this machine (pg_lsclusters found none)")
    workdir = Path(workdir or tempfile.mkdtemp(prefix="load-"))
    load_before = os.getloadavg()[0]
    try:
        options = {"study_script": study_script} if study_script else {}
        with harness.Server(workdir, workers=workers, threads=threads, demo_table=demo_table, env=env,
                            **options) as server:
            cfg = client.Config(base_url=server.base_url, slug=server.study[0], participants=participants,
                                window=window, pace=pace, run_id=f"load{os.getpid()}", seed=seed)
            stats = client.Stats()

            async def fault(stats):
                await asyncio.sleep(fault_at)
                start = time.monotonic()
                try:
                    await harness.restart_postgres(cluster)
                finally:
                    stats.fault.append((start, time.monotonic()))

            asyncio.run(client.run_participants(cfg, stats, fault if cluster else None))
            db = harness.check_database(server.db_url, cfg.slug, stats)
            result = summarise(stats, db)
            result.update(server_statuses=dict(server.server_statuses()), study=server.study,
                          setup={"participants": participants, "window": window, "pace": pace,
                                 "fault_at": fault_at, "workers": server.workers,
                                 "threads": server.env.get("GUNICORN_THREADS", "4"),
                                 "load_before": load_before, "cores": os.cpu_count()})
            if inspect is not None:
                result["inspected"] = inspect(server)
    finally:
        if cluster:
            harness.ensure_postgres_running(cluster)
    return result


def in_fault(start, seconds, faults) -> bool:
    """Was the request in flight during a fault?  Under load a request may wait in the server's
    queue for a while, so one sent before the restart can reach the database while it is down."""
    return any(start <= b + FAULT_GRACE and start + seconds >= a for a, b in faults)


def summarise(stats: client.Stats, db: dict) -> dict:
    attempts = [(ep, *a) for ep, rows in stats.attempts.items() for a in rows]
    answered = [a for a in attempts if a[3] != 0]
    duration = (stats.ended or time.monotonic()) - stats.started
    per_second = Counter(int(start - stats.started) for _, start, _, _ in answered)
    latency = {}
    for endpoint in ("entry", "step", "answer"):
        ok = [sec * 1000 for ep, _, sec, status in attempts if ep == endpoint and status in (200, 302)]
        latency[endpoint] = {"n": len(ok), **{f"p{q}": percentile(ok, q) for q in (50, 95, 99)},
                             "max": max(ok, default=float("nan"))}
    saves = [s * 1000 for s in stats.save_times]
    unexpected = Counter()
    for ep, start, seconds, status in attempts:
        if (status >= 500 or status == 0) and not in_fault(start, seconds, stats.fault):
            unexpected[(ep, status or "no response")] += 1
    return {
        "duration_s": duration, "requests": len(answered), "rps": len(answered) / duration if duration else 0,
        "peak_rps": max(per_second.values(), default=0), "latency_ms": latency,
        "save_ms": {f"p{q}": percentile(saves, q) for q in (50, 95, 99)} | {"max": max(saves, default=0)},
        "errors": {f"{ep} {kind}": n for (ep, kind), n in sorted(stats.errors.items())},
        "errors_outside_fault": {f"{ep} {st}": n for (ep, st), n in sorted(unexpected.items(), key=str)},
        "fault_s": [round(b - a, 2) for a, b in stats.fault],
        "fault_at_s": [round(a - stats.started, 1) for a, _ in stats.fault],
        "finished": len(stats.finished), "failed": dict(stats.failed), "db": db,
    }


def verdict(result: dict) -> dict:
    db = result["db"]
    return {
        f"p95 answer post <= {P95_ANSWER_BAR_MS} ms": result["latency_ms"]["answer"]["p95"] <= P95_ANSWER_BAR_MS,
        "zero lost or duplicated answers": not db["lost"] and not db["duplicated"] and not db["mismatched"],
        "every participant finished, one condition each": (not result["failed"] and not db["missing_participants"]
                                                            and not db["pids_with_several_participants"]),
        "condition counts within 1": db["balance"] <= 1,
        "no 5xx outside the fault": not result["errors_outside_fault"],
    }


def report(result: dict) -> str:
    s, db = result["setup"], result["db"]
    fault = (f"PostgreSQL restarted at {result['fault_at_s'][0]:.1f} s (unavailable {result['fault_s'][0]:.1f} s)"
             if result["fault_s"] else "no fault")
    lines = [
        f"{s['participants']} participants arriving within {s['window']:.0f} s, pauses at pace {s['pace']} "
        f"(1.0 = realistic, tests/load/client.py DWELL); {fault}",
        f"server: scripts/serve.sh, gunicorn {s['workers']} workers x {s['threads']} threads, PostgreSQL, "
        f"Redis cache; {s['cores']} cores, load average {s['load_before']:.2f} before, "
        f"{os.getloadavg()[0]:.2f} after",
        f"study {result['study'][0]}: {result['study'][1]} conditions, {result['study'][2]} tests",
        f"duration {result['duration_s']:.1f} s, {result['requests']} requests, {result['rps']:.1f} requests/s "
        f"(busiest second {result['peak_rps']})",
        "latency of successful responses (ms):",
        f"  {'endpoint':<10}{'n':>7}{'p50':>9}{'p95':>9}{'p99':>9}{'max':>9}",
    ]
    for endpoint, lat in result["latency_ms"].items():
        lines.append(f"  {endpoint:<10}{lat['n']:>7}{lat['p50']:>9.1f}{lat['p95']:>9.1f}{lat['p99']:>9.1f}"
                     f"{lat['max']:>9.1f}")
    sv = result["save_ms"]
    lines.append(f"  answer saved, first try to acknowledged (retries included): p50 {sv['p50']:.1f}, "
                 f"p95 {sv['p95']:.1f}, p99 {sv['p99']:.1f}, max {sv['max']:.1f}")
    lines.append("errors by kind (every attempt): " + (", ".join(f"{k} x{n}" for k, n in result["errors"].items())
                                                      or "none"))
    lines.append("5xx / no response outside the fault: "
                 + (str(result["errors_outside_fault"]) if result["errors_outside_fault"] else "none"))
    lines.append(f"server status codes (access log): {dict(sorted(result['server_statuses'].items()))}")
    lines.append(f"database: {db['answers_acked']} answers acknowledged, {db['answers_stored']} stored; "
                 f"lost {len(db['lost'])}, duplicated {len(db['duplicated'])}, mismatched {len(db['mismatched'])}, "
                 f"stored but never acknowledged {len(db['unacknowledged'])}")
    lines.append(f"participants: {db['participants']} in the database, {result['finished']} saw their completion "
                 f"code, {len(result['failed'])} failed, {len(db['pids_with_several_participants'])} with more "
                 f"than one participant, wrong codes {len(db['wrong_codes'])}")
    lines.append(f"per condition: {db['per_condition']} (max - min = {db['balance']})")
    for reason in list(result["failed"].values())[:5]:
        lines.append(f"  failed: {reason}")
    for bar, ok in verdict(result).items():
        lines.append(f"{'PASS' if ok else 'FAIL'}  {bar}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--participants", type=int, default=500)
    parser.add_argument("--window", type=float, default=60.0, help="arrivals spread over this many seconds")
    parser.add_argument("--pace", type=float, default=1.0,
                        help="scale of the pauses on each step (1.0: a quick but genuine participant, "
                        "about 4.5 minutes for the demo study)")
    parser.add_argument("--fault-at", type=float, default=None,
                        help="restart PostgreSQL this many seconds in (default: half the window)")
    parser.add_argument("--no-fault", action="store_true", help="do not restart PostgreSQL")
    parser.add_argument("--workers", type=int, default=None, help="gunicorn workers (default 2 x cores + 1)")
    parser.add_argument("--threads", type=int, default=None, help="threads per worker (default 4)")
    parser.add_argument("--workdir", default=None, help="logs go here (default: a new temporary directory)")
    args = parser.parse_args(argv)
    if not 1 <= args.participants <= 5000:
        parser.error("--participants must be between 1 and 5000")
    fault_at = None if args.no_fault else (args.fault_at if args.fault_at is not None else args.window / 2)
    result = run_load(args.participants, args.window, args.pace, fault_at, args.workdir, args.workers,
                      args.threads)
    print(report(result))
    return 0 if all(verdict(result).values()) else 1


if __name__ == "__main__":
    sys.exit(main())
