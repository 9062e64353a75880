"""Benchmark: all teaching sequences, the full τ/λ sweep and the ideal-user matrix at paper size.

    .venv/bin/python bench/teaching.py [--envs 21216] [--thetas 1000] [--candidates 6]

Uses a synthetic table of the paper's shape (teaching.domains.driving.synthetic); building it
is timed separately.  Prints wall time per stage and peak memory (Python
allocations by tracemalloc, and the process's peak RSS).
"""
from __future__ import annotations

import argparse
import resource
import sys
import time
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from teaching.core.conditions import teach
from teaching.core.evaluation import ideal_user_matrix
from teaching.core.learners import Distances
from teaching.domains.driving.synthetic import synthetic_table


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--envs", type=int, default=21216)
    p.add_argument("--thetas", type=int, default=1000)
    p.add_argument("--candidates", type=int, default=6)
    args = p.parse_args()

    t0 = time.perf_counter()
    table = synthetic_table(args.envs, args.thetas, n_candidates=args.candidates, seed=0)
    t_build = time.perf_counter() - t0
    print(f"synthetic table {table.n_envs} envs x {table.n_thetas} thetas built in {t_build:.1f} s "
          f"(not part of the budget)")

    tracemalloc.start()
    t0 = time.perf_counter()
    dist = Distances(table)
    _ = dist.reward, dist.euclidean, dist.strategy
    t_dist = time.perf_counter() - t0
    result = teach(table, seed=0, dist=dist)
    t_teach = time.perf_counter() - t0 - t_dist
    envs = {k: s.envs for k, s in result.sequences.items()}
    matrix = ideal_user_matrix(result.models, envs, dist)
    total = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux

    print(f"distances (reward, euclidean, strategy): {t_dist:6.1f} s")
    print(f"sweeps + 9 conditions (greedy, coverage, 1000 random draws): {t_teach:6.1f} s")
    print(f"ideal-user matrix 8 x 7: {total - t_dist - t_teach:6.1f} s")
    print(f"TOTAL (budget 60 s): {total:.1f} s")
    print(f"peak traced memory during teaching: {peak / 2**20:.0f} MiB; process peak RSS: {rss:.0f} MiB "
          f"(includes the {table.features.nbytes / 2**20:.0f} MiB table features)")
    for name, m in result.models.items():
        s = result.sequences[name]
        print(f"  {str(m):32s} {len(s.envs):2d} examples ({s.n_unique} unique)  P(θ*) = "
              f"{s.p[-1] if s.p else s.prior:.3f}  rule met: {result.rule_met.get(name, '-')}")
    print("matrix rows = sequences, columns = users:")
    for row in matrix:
        print("  " + " ".join(f"{v:5.2f}" for v in row))


if __name__ == "__main__":
    main()
