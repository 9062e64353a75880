"""Benchmark: closed-loop decisions with many participants answering at once.

    .venv/bin/python bench/loop_latency.py --table var/tables/paper [--participants 200] \\
        [--json docs/bench_loop_latency.json] [--update-doc docs/benchmarks.md]
    .venv/bin/python bench/loop_latency.py --synthetic-paper      # a table of the paper's shape, built here

The production server (tests/load: scripts/serve.sh, gunicorn + Celery, PostgreSQL, Redis cache, a fresh
database) serves a study of one closed-loop condition on the table (the default settings: approx*, a check
after every 2 examples, feedback); --participants simulated participants (tests/load/client.py) arrive within
--window seconds, so that they are all in the loop together, and go through it at each --pace in turn (a
fresh server each): 1.0, a quick but genuine participant's pauses, and 0.05, twenty times as fast, to see
where the server saturates.  The bars hold for pace 1; the exit status is 0 when they do.  Figures:

* decision time: every LoopStep's ``seconds`` (studyapp.participant.closedloop._decide: reading the participant's steps
  and answers, ClosedLoop.decide, under the real concurrency of the run), p50 / p95 / max;
* the HTTP latency of the step pages (where a decision is made, when one is due) and of the answer posts;
* per gunicorn worker, from /proc/PID/smaps: resident and proportional set size (PSS: a page shared by n
  processes counts 1/n in each), the part of it private to that worker, and the pack's mapped files (the
  read-only arrays every worker maps, studyapp.participant.closedloop): their resident size and PSS.  Bars: decision
  p95 <= 150 ms; the pack's arrays shared, not copied (their PSS per worker below their resident size).

The paper table takes about 25 minutes to build on an idle 2-core machine (docs/benchmarks.md);
--synthetic-paper builds a table of its shape (21,216 environments x 1,000 θ, teaching's synthetic_table:
the same array sizes, so the same work per decision) in a few minutes instead, and the output says which.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.doc_section import rewrite_section  # noqa: E402
from tests.load import harness, run  # noqa: E402

BEGIN, END = "<!-- bench/loop_latency.py: begin -->", "<!-- bench/loop_latency.py: end -->"
P95_BAR_MS = 150
SETTINGS = {"check_every": 2, "feedback": True}

# Run by the server's harness after migrate: one closed-loop condition on $LOOP_TABLE, its final tests as
# any study's (select_test_set), every participant in it.
LOOP_STUDY = """
import json, os
import django
django.setup()
from studyapp.researcher.studies import build_study, table_spec
spec = table_spec(os.environ["LOOP_TABLE"], slug="loop-bench", sequences={})
spec["conditions"] = [{"name": "closed-loop", "closed_loop": json.loads(os.environ["LOOP_SETTINGS"])}]
spec.update(name="Closed-loop latency", target_per_condition=100000, completion_code="LOOPBENCH")
study = build_study(spec)
print(study.slug, study.conditions.count(), len(study.test_set))
"""


def synthetic_paper(out: Path) -> Path:
    """A synthetic table of the paper's shape saved under `out` (teaching's synthetic_table)."""
    from teaching.domains.driving.synthetic import synthetic_table  # noqa: PLC0415

    # with its real knots (1.7 GB), so that its trajectories differ and a test set can be drawn from them
    synthetic_table(21216, 1000, seed=0, max_stored=21216 * 1000).save(out)
    return out


def smaps(pid: int, marker: str) -> dict:
    """Resident, PSS and private kB of process `pid`, in all and in the mappings whose path holds `marker`."""
    total = {"rss": 0, "pss": 0, "private": 0}
    pack = {"rss": 0, "pss": 0, "size": 0}
    current = None
    with open(f"/proc/{pid}/smaps") as f:
        for line in f:
            fields = line.split()
            if not fields[0].endswith(":"):  # a mapping's header: address perms offset dev inode [path]
                current = pack if len(fields) > 5 and marker in fields[5] else None
                continue
            key, kb = fields[0][:-1], int(fields[1]) if len(fields) > 1 and fields[1].isdigit() else 0
            if key == "Rss":
                total["rss"] += kb
            elif key == "Pss":
                total["pss"] += kb
            elif key in ("Private_Clean", "Private_Dirty"):
                total["private"] += kb
            if current is not None and key in ("Rss", "Pss", "Size"):
                current[key.lower()] += kb
    return {**total, "pack": pack}


def gunicorn_workers() -> list[int]:
    """PIDs of gunicorn workers: gunicorn processes whose parent is a gunicorn process."""
    out = subprocess.run(["ps", "-eo", "pid=,ppid=,args="], capture_output=True, text=True).stdout
    procs = {int(p): (int(pp), args) for p, pp, args in (line.split(None, 2) for line in out.splitlines()
                                                        if len(line.split(None, 2)) == 3)}
    return sorted(pid for pid, (ppid, args) in procs.items()
                  if "gunicorn" in args and "gunicorn" in procs.get(ppid, (0, ""))[1])


def inspect(server) -> dict:
    """What the run left: every decision's time (from the database) and each web worker's memory."""
    with harness.connect(server.db_url) as conn:
        rows = conn.execute("SELECT kind, seconds FROM studyapp_loopstep").fetchall()
    workers = {pid: smaps(pid, "/closedloop/") for pid in gunicorn_workers()}
    return {"decisions": [[kind, float(s)] for kind, s in rows], "workers": workers}


def figures(result: dict, table: str, synthetic: bool, args, pace: float) -> dict:
    seconds = np.array([s for _, s in result["inspected"]["decisions"]]) * 1000
    kinds = {}
    for kind, _ in result["inspected"]["decisions"]:
        kinds[kind] = kinds.get(kind, 0) + 1
    workers = list(result["inspected"]["workers"].values())
    mb = 1 / 1024
    return {
        "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "table": table, "synthetic": synthetic,
        "participants": args.participants, "window_s": args.window, "pace": pace, "settings": SETTINGS,
        "cores": os.cpu_count(), "load_before": result["setup"]["load_before"], "load_after": os.getloadavg()[0],
        "gunicorn": f"{result['setup']['workers']} workers x {result['setup']['threads']} threads",
        "decisions": int(len(seconds)), "kinds": kinds,
        "decision_ms": {"p50": float(np.percentile(seconds, 50)), "p95": float(np.percentile(seconds, 95)),
                        "max": float(seconds.max())} if len(seconds) else {},
        "http_ms": {ep: {k: result["latency_ms"][ep][k] for k in ("n", "p50", "p95", "max")}
                    for ep in ("step", "answer")},
        "finished": result["finished"], "failed": len(result["failed"]),
        "errors": result["errors"], "db_lost": len(result["db"]["lost"]),
        "db_duplicated": len(result["db"]["duplicated"]), "db_mismatched": len(result["db"]["mismatched"]),
        "workers_mb": [{"rss": w["rss"] * mb, "pss": w["pss"] * mb, "private": w["private"] * mb,
                        "pack_size": w["pack"]["size"] * mb, "pack_rss": w["pack"]["rss"] * mb,
                        "pack_pss": w["pack"]["pss"] * mb} for w in workers],
    }


def verdicts(fig: dict) -> dict:
    shared = [w["pack_pss"] < 0.75 * w["pack_rss"] for w in fig["workers_mb"] if w["pack_rss"] > 0]
    return {
        f"decision p95 <= {P95_BAR_MS} ms": bool(fig["decision_ms"]) and fig["decision_ms"]["p95"] <= P95_BAR_MS,
        "every participant finished, no answer lost, duplicated or changed": (
            fig["failed"] == 0 and fig["finished"] == fig["participants"]
            and not (fig["db_lost"] or fig["db_duplicated"] or fig["db_mismatched"])),
        "the pack's arrays shared between the workers (PSS below resident size)": len(shared) > 1 and all(shared),
    }


def report(fig: dict) -> str:
    which = "a synthetic table of the paper's shape" if fig["synthetic"] else "the table"
    d, lines = fig["decision_ms"], []
    lines.append(f"{fig['participants']} participants arriving within {fig['window_s']:g} s at pace {fig['pace']} "
                 f"through one closed-loop condition ({json.dumps(fig['settings'])}) on {which} at {fig['table']}; "
                 f"gunicorn {fig['gunicorn']}; {fig['cores']} cores, load average {fig['load_before']:.2f} before, "
                 f"{fig['load_after']:.2f} after")
    lines.append(f"decisions: {fig['decisions']} ({', '.join(f'{k} {n}' for k, n in sorted(fig['kinds'].items()))});"
                 f" time per decision p50 {d['p50']:.1f} ms, p95 {d['p95']:.1f} ms, max {d['max']:.1f} ms")
    for ep, h in fig["http_ms"].items():
        lines.append(f"HTTP {ep}: n {h['n']}, p50 {h['p50']:.1f} ms, p95 {h['p95']:.1f} ms, max {h['max']:.1f} ms")
    lines.append(f"finished {fig['finished']}, failed {fig['failed']}; lost {fig['db_lost']}, duplicated "
                 f"{fig['db_duplicated']}, changed {fig['db_mismatched']}; errors {fig['errors'] or 'none'}")
    for i, w in enumerate(fig["workers_mb"]):
        lines.append(f"worker {i}: resident {w['rss']:.0f} MB, PSS {w['pss']:.0f} MB, private "
                     f"{w['private']:.0f} MB; pack mapped {w['pack_size']:.0f} MB, resident {w['pack_rss']:.0f} MB, "
                     f"PSS {w['pack_pss']:.0f} MB")
    for bar, ok in verdicts(fig).items():
        lines.append(f"{'PASS' if ok else 'FAIL'}  {bar}")
    return "\n".join(lines)


def markdown(data: dict) -> str:
    runs = data["runs"]
    first = runs[0]
    which = ("a synthetic table of the paper's shape (21,216 × 1,000, `--synthetic-paper`)" if first["synthetic"]
             else f"`{first['table']}`")
    latency = "\n".join(
        f"| {f['pace']:g} | {f['decisions']} | {f['decision_ms']['p50']:.1f} | {f['decision_ms']['p95']:.1f} | "
        f"{f['decision_ms']['max']:.0f} | {f['http_ms']['step']['p50']:.0f} / {f['http_ms']['step']['p95']:.0f} | "
        f"{f['http_ms']['answer']['p50']:.0f} / {f['http_ms']['answer']['p95']:.0f} | "
        f"{f['finished']} of {f['participants']}, lost {f['db_lost']} | {f['load_before']:.2f} → "
        f"{f['load_after']:.2f} |" for f in runs)
    memory = "\n".join(
        f"| {f['pace']:g} | {i} | {w['rss']:.0f} | {w['pss']:.0f} | {w['private']:.0f} | {w['pack_size']:.0f} | "
        f"{w['pack_rss']:.0f} | {w['pack_pss']:.0f} |" for f in runs for i, w in enumerate(f["workers_mb"]))
    checks = "\n".join(f"* pace {f['pace']:g}: " + "; ".join(f"{'**pass**' if ok else '**fail**'}: {bar}"
                                                              for bar, ok in verdicts(f).items()) for f in runs)
    return f"""{BEGIN}
`bench/loop_latency.py --json JSON`, {first['when']}, on {which}: {first['participants']} simulated participants
arriving within {first['window_s']:g} s (tests/load's client, all in the loop together) through one closed-loop
condition with the default settings ({json.dumps(first['settings'])}), served by scripts/serve.sh (gunicorn
{first['gunicorn']}, PostgreSQL, Redis) on {first['cores']} cores, otherwise idle.  Pace 1 is a quick but
genuine participant (a training page watched for 7 s, a test answered in 30 s); pace {runs[-1]['pace']:g} sends
the same participants {1 / runs[-1]['pace']:.0f} times as fast, far beyond what 200 people do, to see where the
server saturates.  Decision time is `LoopStep.seconds`: reading the participant's steps and answers and
deciding, in the request, under the run's load; times in ms.  Generated by
`python bench/loop_latency.py --update-doc JSON docs/benchmarks.md`.

| pace | decisions | p50 | p95 | max | step page p50 / p95 | answer p50 / p95 | finished | load |
|---|---|---|---|---|---|---|---|---|
{latency}

Memory per gunicorn worker after each run (MB; PSS counts a page shared by n processes 1/n in each; "pack":
the closed loop's read-only arrays, mapped from disk by every worker):

| pace | worker | resident | PSS | private | pack mapped | pack resident | pack PSS |
|---|---|---|---|---|---|---|---|
{memory}

{checks}
{END}"""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    src = parser.add_mutually_exclusive_group()
    src.add_argument("--table", help="trajectory table directory (e.g. var/tables/paper)")
    src.add_argument("--synthetic-paper", action="store_true", help="build a table of the paper's shape and use it")
    parser.add_argument("--participants", type=int, default=200)
    parser.add_argument("--window", type=float, default=5.0, help="arrivals spread over this many seconds")
    parser.add_argument("--pace", type=float, nargs="+", default=[1.0, 0.05],
                        help="scale of each pause (tests/load/client.py; 1.0: a quick but genuine participant); "
                             "one run per value, on one table")
    parser.add_argument("--workers", type=int, default=None, help="gunicorn workers (default 2 x cores + 1)")
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--update-doc", nargs=2, metavar=("JSON", "DOC"), help="rewrite DOC's section from JSON")
    args = parser.parse_args(argv)
    if args.update_doc:
        rewrite_section(Path(args.update_doc[0]), Path(args.update_doc[1]), BEGIN, END, markdown, "loop latency")
        return 0
    if not (args.table or args.synthetic_paper):
        parser.error("give --table or --synthetic-paper")
    runs = []
    with tempfile.TemporaryDirectory(prefix="loop-bench-") as tmp:
        table = Path(args.table).resolve() if args.table else None
        if table is None:
            t0 = time.perf_counter()
            table = synthetic_paper(Path(tmp) / "table")
            print(f"built a synthetic table of the paper's shape in {time.perf_counter() - t0:.0f} s", flush=True)
        env = {"LOOP_TABLE": str(table), "LOOP_SETTINGS": json.dumps(SETTINGS)}
        for i, pace in enumerate(args.pace):
            result = run.run_load(args.participants, args.window, pace, fault_at=None, workdir=Path(tmp) / f"run{i}",
                                  workers=args.workers, study_script=LOOP_STUDY, env=env, inspect=inspect)
            print(run.report(result), end="\n\n")  # the load test's own figures and database checks
            fig = figures(result, str(args.table or "synthetic"), args.synthetic_paper, args, pace)
            if not fig["decisions"]:
                print("no closed-loop decision was stored: see the failures above")
                return 1
            print(report(fig), end="\n\n", flush=True)
            runs.append(fig)
    if args.json:
        args.json.write_text(json.dumps({"runs": runs}, indent=1) + "\n")
    return 0 if all(all(verdicts(f).values()) for f in runs if f["pace"] >= 1.0) else 1


if __name__ == "__main__":
    sys.exit(main())
