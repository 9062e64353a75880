"""Planner benchmark (issue 2): speed against per-problem SciPy, projected paper
time, peak memory, and optimality against an 8-start SciPy reference.

    python bench/planner.py [--envs 64] [--pairs 1000] [--scipy-problems 40]

Everything is measured in this one run on this machine; the figures printed
are the ones to quote.  Bars: >= 100x SciPy, >= 6,000 trajectories/s end to
end (paper table <= 60 min), peak memory <= 6 GB, >= 99 % of pairs within 1e-3
of the reference and none worse than 1e-2.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from teaching.build import PRESETS, assemble, chunk_key, chunks_of, table_identity  # noqa: E402
from teaching.candidates import sample_thetas  # noqa: E402
from teaching.environments import N_ENVIRONMENTS, get_environments, other_car_states  # noqa: E402
from teaching.features import default_normalisers  # noqa: E402
from teaching.planner import objective_weights, plan_chunk, strategy_seeds  # noqa: E402
from teaching.reference import reference_gap, solve_scipy  # noqa: E402
from teaching.table import TrajectoryTable  # noqa: E402

PAPER = N_ENVIRONMENTS * 1000


def peak_rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2


def paper_assembly(out: Path) -> None:
    """Child process: write paper-shaped chunk files, assemble them, load with verification."""
    preset = PRESETS["paper"]
    thetas = sample_thetas(preset.n_thetas)
    norm = default_normalisers()
    identity = table_identity(preset, thetas, norm)
    env_ids = preset.env_ids()
    rng = np.random.default_rng(0)
    for chunk in chunks_of(env_ids, preset.chunk_size):
        m = len(chunk)
        path = out / "chunks" / f"{chunk_key(identity, chunk)}.npz"
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, env_ids=chunk,
                 controls=rng.uniform(-1, 1, (m, preset.n_thetas, 10, 2)).astype(np.float32),
                 features=rng.uniform(0, 1, (m, preset.n_thetas, 5)),
                 strategy=rng.integers(0, 8, (m, preset.n_thetas)).astype(np.int8),
                 d_euclid=rng.uniform(0, 5, (m, preset.n_thetas)).astype(np.float32))
    table = assemble(out, preset, identity, env_ids, thetas, norm)
    TrajectoryTable.load(out, verify=True)
    print(f"{table.n_envs:,} x {table.n_thetas:,}, {sum(f.stat().st_size for f in out.glob('*.npy')) / 1e9:.2f} GB on disk")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--envs", type=int, default=64, help="environments planned (x 1000 thetas)")
    ap.add_argument("--pairs", type=int, default=1000, help="(E, theta) pairs checked against the reference")
    ap.add_argument("--scipy-problems", type=int, default=40, help="problems timed with per-problem SciPy")
    ap.add_argument("--scratch", default=None, help="directory for the 5 GB paper-assembly scratch files")
    ap.add_argument("--paper-assembly", metavar="DIR", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.paper_assembly:
        return paper_assembly(Path(args.paper_assembly))

    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start")
    rng = np.random.default_rng(2024)
    thetas = sample_thetas(1000)  # the paper preset's Theta
    norm = default_normalisers()
    env_ids = np.sort(rng.choice(N_ENVIRONMENTS, args.envs, replace=False))  # uniform: the paper's class mix
    plan_chunk(env_ids[:2], thetas[:16], norm)  # compile outside the timing

    # --- batched planner, end to end (anchors, warm starts, cross-theta, labels, distances)
    stats: dict = {}
    t0 = time.perf_counter()
    parts = [plan_chunk(c, thetas, norm, stats=stats) for c in np.array_split(env_ids, max(1, args.envs // 32))]
    t_plan = time.perf_counter() - t0
    result = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    n_traj = args.envs * len(thetas)
    rate = n_traj / t_plan
    print(f"\nbatched planner: {n_traj:,} optimal trajectories in {t_plan:.1f} s = {rate:,.0f} trajectories/s")
    print(f"  Newton solves {stats['solves']:,} ({stats['solves'] / n_traj:.2f} per trajectory), "
          f"{stats['iterations'] / stats['solves']:.1f} iterations per solve, "
          f"{stats['moved']:,} improved by the cross-theta step")

    # --- per-problem SciPy, same problems, the same 8 strategy seeds as starts
    seeds = strategy_seeds()
    probs = [(int(rng.integers(args.envs)), int(rng.integers(len(thetas)))) for _ in range(args.scipy_problems)]
    t0 = time.perf_counter()
    for m, n in probs:
        env = get_environments(env_ids[[m]])
        oxy = other_car_states(env)[0]
        w = objective_weights(thetas[n], norm)[0]
        for s in seeds:
            solve_scipy(s, oxy, env.goal[0], w)
    t_scipy = time.perf_counter() - t0
    scipy_rate = len(probs) / t_scipy
    print(f"per-problem scipy L-BFGS-B (exact gradient, 8 starts): {scipy_rate:.2f} trajectories/s "
          f"({scipy_rate * len(seeds):.1f} single-start solves/s)")
    print(f"  speed-up: {rate / scipy_rate:,.0f}x against the same 8 starts, "
          f"{rate / (scipy_rate * len(seeds)):,.0f}x against a single start   [bar >= 100x]")
    print(f"projected paper table ({PAPER:,} trajectories) at this rate: {PAPER / rate / 60:.1f} min on this machine"
          f"   [bar <= 60 min, >= 6,000 trajectories/s]")

    # --- peak memory of the paper build: the real assembly and verified load, on 21,216 x 1,000
    # synthetic chunk files (planning them all is the hour the projection above is about).
    with tempfile.TemporaryDirectory(dir=args.scratch) as tmp:
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, __file__, "--paper-assembly", tmp], capture_output=True, text=True)
        if proc.returncode:
            raise SystemExit(proc.stderr)
        child_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024**2
        print(f"\npaper-sized assembly + verified load ({proc.stdout.strip()}) in {time.perf_counter() - t0:.0f} s: "
              f"peak resident memory {child_peak:.2f} GB   [bar <= 6 GB]")
    print(f"peak resident memory of the planning above (this process): {peak_rss_gb():.2f} GB; "
          f"it does not grow with the number of environments (one chunk at a time)")

    # --- optimality against the 8-start SciPy reference
    table = TrajectoryTable(thetas=thetas, env_ids=env_ids, normalisers=norm, **result)
    pairs = np.stack([rng.integers(0, args.envs, args.pairs), rng.integers(0, len(thetas), args.pairs)], 1)
    t0 = time.perf_counter()
    gap = reference_gap(table, pairs)
    print(f"\noptimality on {args.pairs} random (E, theta) pairs vs best of 8-start SciPy "
          f"({time.perf_counter() - t0:.0f} s):")
    print(f"  within 1e-3: {np.mean(gap <= 1e-3):.2%}   [bar >= 99 %]")
    print(f"  worse than 1e-2: {int(np.sum(gap > 1e-2))}   [bar 0]   largest gap {gap.max():.2e}")
    print(f"  table strictly better than the reference: {np.mean(gap < -1e-6):.2%}")
    print(f"  min d_reward over the planned table: {table.d_reward().min():.3g}   [must be >= 0]")
    print(f"\nload average at end {os.getloadavg()[0]:.2f} (other processes on the machine slow every figure above)")


if __name__ == "__main__":
    main()
