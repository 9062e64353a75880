"""Benchmark: each registered selector's time on one or more tables (the demo table, the paper one).

    .venv/bin/python bench/teaching_selectors.py --table var/tables/demo \
        --table var/tables/paper:scot,bec-scaffold,highlights [--paper-synthetic] [--only NAMES] \
        [--quiet-load 1.2] [--json docs/bench_teaching_selectors.json]
    .venv/bin/python bench/teaching_selectors.py --update-doc docs/bench_teaching_selectors.json docs/benchmarks.md

--table DIR[:NAMES] (repeatable): a built table (`python -m teaching build --preset demo --out DIR`),
optionally with the comma-separated selectors to time on it (default: --only's, else every registered
one).  --paper-synthetic: also time the BEC selectors on a synthetic table of the paper's shape
(teaching.domains.driving.synthetic: 6 candidate trajectories per environment, so fewer distinct
constraints than the planner's table).  Each selector runs alone (its own SelectionContext: learner
fits and sweeps count in a greedy one's time; the table's distances, computed once per table, do
not, and are printed apart).  --quiet-load waits, before each table (up to 15 minutes), until the
1-minute load average is below the given value; the load at each table's start and end is recorded
either way, since other processes on the machine slow every figure.  The bar: SCOT and bec-scaffold
within 2 minutes each on a table of the paper's size, on 2 cores; the exit status is 0 when it holds.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import time
from pathlib import Path

# the repository instead of bench/: this file's name would otherwise shadow the standard library's
# selectors module, which subprocess (imported by SciPy) needs (imported as bench.teaching_selectors,
# by a test, bench/ is not on the path and nothing is removed)
if sys.path and Path(sys.path[0]).resolve() == Path(__file__).resolve().parent:
    sys.path.pop(0)
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.doc_section import rewrite_section
from teaching.core.conditions import condition_sequence
from teaching.core.learners import METRICS, Distances
from teaching.core.selectors import selector_names
from teaching.core.table import TrajectoryTable

BEC_SELECTORS = ("scot", "bec-scaffold", "highlights")
BAR_SELECTORS, BAR_SECONDS = ("scot", "bec-scaffold"), 120.0
PAPER_SHAPE = (21216, 1000)  # environments x θ of the paper preset, where the bar applies
MAX_WAIT_S = 15 * 60
BEGIN, END = "<!-- bench/teaching_selectors.py: begin -->", "<!-- bench/teaching_selectors.py: end -->"


def wait_for_quiet(below: float) -> float:
    """Sleep until the 1-minute load average is below `below` (at most MAX_WAIT_S); the seconds waited."""
    t0 = time.monotonic()
    while os.getloadavg()[0] >= below and time.monotonic() - t0 < MAX_WAIT_S:
        time.sleep(30)
    return time.monotonic() - t0


def time_selectors(table, names, label: str) -> dict:
    """One table's figures: its shape, the distances' seconds and each selector's seconds and length."""
    fig = {"table": label, "shape": [table.n_envs, table.n_thetas, int(table.features.shape[-1])],
           "load_start": os.getloadavg()[0], "selectors": []}
    print(f"{label}: {table.n_envs} environments x {table.n_thetas} θ x {fig['shape'][2]} features, "
          f"load average {fig['load_start']:.2f}")
    t0 = time.perf_counter()
    dist = Distances(table)
    for metric in (*METRICS, "theta_norms"):  # built on first use: here, not in the first selector's time
        getattr(dist, metric)
    fig["distances_seconds"] = time.perf_counter() - t0
    print(f"  {'(distances)':18s} {fig['distances_seconds']:8.2f} s")
    for name in names:
        load, t0 = os.getloadavg()[0], time.perf_counter()
        seq = condition_sequence(table, name, seed=0, dist=dist)[0]
        row = {"name": name, "seconds": time.perf_counter() - t0, "length": len(seq.envs),
               "load_start": load, "load_end": os.getloadavg()[0]}
        fig["selectors"].append(row)
        print(f"  {name:18s} {row['seconds']:8.2f} s  {row['length']:3d} examples  load average "
              f"{row['load_start']:.2f} -> {row['load_end']:.2f}  {verdict(fig, row)}")
    fig["load_end"] = os.getloadavg()[0]
    return fig


def verdict(table_fig: dict, row: dict) -> str:
    """'met' / 'not met' where the bar applies (SCOT and bec-scaffold at the paper's size), else ''."""
    if row["name"] not in BAR_SELECTORS or tuple(table_fig["shape"][:2]) != PAPER_SHAPE:
        return ""
    return "met" if row["seconds"] <= BAR_SECONDS else "not met"


def markdown(fig: dict) -> str:
    rows = "\n".join(
        f"| `{t['table']}` | {t['shape'][0]:,} × {t['shape'][1]:,} | {r['name']} | **{r['seconds']:.2f}** | "
        f"{r['length']} | {r['load_start']:.2f} → {r['load_end']:.2f} | "
        + (f"≤ {BAR_SECONDS:.0f} s: **{verdict(t, r)}**" if verdict(t, r) else "") + " |"
        for t in fig["tables"] for r in t["selectors"])
    distances = ", ".join(f"`{t['table']}` {t['distances_seconds']:.2f} s" for t in fig["tables"])
    waited = ", ".join(f"{t['waited_seconds']:.0f} s" for t in fig["tables"])
    return (f"{BEGIN}\n`bench/teaching_selectors.py {fig['argv']}`, {fig['date']}, {fig['cpu_count']} cores, "
            f"load average {fig['load_start']:.2f} when it started and {fig['load_end']:.2f} at the end (around each "
            f"selector: in the table; before each table it waited {waited} for a quieter machine).  Seconds of wall "
            f"time per selector, alone; the table's distances, computed once before them, took {distances}.  "
            "Generated by `python bench/teaching_selectors.py --update-doc JSON docs/benchmarks.md`.\n\n"
            "| table | size | selector | seconds | examples | load average | bar |\n"
            f"|---|---|---|---|---|---|---|\n{rows}\n{END}")


def parse_table(spec: str) -> tuple[Path, list[str] | None]:
    path, _, names = spec.partition(":")
    return Path(path), names.split(",") if names else None


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--table", action="append", default=[], type=parse_table, metavar="DIR[:NAMES]")
    p.add_argument("--paper-synthetic", action="store_true")
    p.add_argument("--only", help="comma-separated selectors (default: all registered)")
    p.add_argument("--quiet-load", type=float, help="before each table, wait until the load average is below this")
    p.add_argument("--json", type=Path, help="also write the figures to this file")
    p.add_argument("--update-doc", nargs=2, type=Path, metavar=("JSON", "DOC"),
                   help="rewrite DOC's teaching-selectors section from a --json output; no run")
    args = p.parse_args(argv)
    if args.update_doc:
        rewrite_section(*args.update_doc, BEGIN, END, markdown, "teaching selectors")
        return 0
    default = args.only.split(",") if args.only else list(selector_names())
    unknown = {n for _, names in args.table for n in names or []} - set(selector_names())
    if unknown or set(default) - set(selector_names()):
        p.error(f"unknown selector(s) {', '.join(sorted(unknown | (set(default) - set(selector_names()))))}")
    runs = [(lambda d=d: TrajectoryTable.load(d), names or default, str(d)) for d, names in args.table]
    if args.paper_synthetic:
        from teaching.domains.driving.synthetic import synthetic_table  # noqa: PLC0415

        runs.append((lambda: synthetic_table(*PAPER_SHAPE, n_candidates=6, seed=0),
                     [n for n in default if n in BEC_SELECTORS], "synthetic paper-size table"))
    fig = {"argv": " ".join(sys.argv[1:] if argv is None else argv),
           "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
           "cpu_count": os.cpu_count(), "load_start": os.getloadavg()[0], "tables": []}
    for load, names, label in runs:
        waited = wait_for_quiet(args.quiet_load) if args.quiet_load else 0.0
        fig["tables"].append({**time_selectors(load(), names, label), "waited_seconds": waited})
    fig["load_end"] = os.getloadavg()[0]
    if args.json:
        args.json.write_text(json.dumps(fig, indent=1))
    return 0 if all(verdict(t, r) != "not met" for t in fig["tables"] for r in t["selectors"]) else 1


if __name__ == "__main__":
    sys.exit(main())
