"""Benchmark: each registered selector's time on a table (the demo table, and a paper-size one).

    .venv/bin/python bench/teaching_selectors.py --table DIR [--paper-synthetic] [--only scot,bec-scaffold]

--table: a built table (e.g. the demo preset: `python -m teaching build --preset demo --out DIR`).
--paper-synthetic: also time the BEC selectors on a synthetic table of the paper's shape (21,216 ×
1,000, teaching.domains.driving.synthetic: 6 candidate trajectories per environment, so fewer
distinct constraints than the planner's table).  Each selector runs alone (its own
SelectionContext: learner fits and sweeps included in a greedy one's time).  Prints wall seconds
and the sequence length; the bar for SCOT and bec-scaffold at paper size is 2 minutes on 2 cores.
Other processes on the machine slow every figure (note the load average).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

# the repository instead of bench/: this file's name would otherwise shadow the standard library's
# selectors module, which subprocess (imported by SciPy) needs
sys.path.pop(0)
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from teaching.core.conditions import condition_sequence
from teaching.core.learners import Distances
from teaching.core.selectors import selector_names
from teaching.core.table import TrajectoryTable

BEC_SELECTORS = ("scot", "bec-scaffold", "highlights")


def time_selectors(table, names, label: str) -> None:
    dist = Distances(table)
    print(f"{label}: {table.n_envs} environments x {table.n_thetas} θ x {table.features.shape[-1]} features")
    for name in names:
        t0 = time.perf_counter()
        seq = condition_sequence(table, name, seed=0, dist=dist)[0]
        print(f"  {name:18s} {time.perf_counter() - t0:8.2f} s  {len(seq.envs):3d} examples")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--table", type=Path)
    p.add_argument("--paper-synthetic", action="store_true")
    p.add_argument("--only", help="comma-separated selectors (default: all registered)")
    args = p.parse_args()
    names = args.only.split(",") if args.only else list(selector_names())
    if args.table:
        time_selectors(TrajectoryTable.load(args.table), names, str(args.table))
    if args.paper_synthetic:
        from teaching.domains.driving.synthetic import synthetic_table  # noqa: PLC0415

        table = synthetic_table(21216, 1000, n_candidates=6, seed=0)
        time_selectors(table, [n for n in names if n in BEC_SELECTORS], "synthetic paper-size table")


if __name__ == "__main__":
    main()
