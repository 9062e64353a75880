"""Build the gridworld's paper-sized table (every yard x 1,000 θ) and print the time, beside the
driving demo table's build in the same run for scale.

    python bench/gridworld.py [--jobs 2] [--keep DIR]

Both builds go to fresh temporary directories (or DIR/gridworld-paper, DIR/demo with --keep), so
every figure is a cold build: planning, assembly and the content hash check on load.  Bar (issue
23): the gridworld paper table in at most 2 minutes on 2 cores.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from teaching.core.build import PRESETS, build_table


def timed_build(preset_name: str, out: Path, jobs: int) -> dict:
    start = time.perf_counter()
    table = build_table(PRESETS[preset_name], out, jobs=jobs)
    seconds = time.perf_counter() - start
    size = sum(f.stat().st_size for f in out.glob("*.npy"))
    return {"preset": preset_name, "seconds": seconds, "envs": table.n_envs, "thetas": table.n_thetas,
            "hash": table.meta["content_hash"][:16], "gb": size / 1e9}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--keep", help="build into this directory and keep the tables")
    args = parser.parse_args(argv)
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-gridworld-"))
    try:
        rows = [timed_build(name, root / name, args.jobs) for name in ("gridworld-paper", "demo")]
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    print(f"{os.cpu_count()} cores, --jobs {args.jobs}")
    for r in rows:
        print(f"{r['preset']:16s} {r['envs']:6,d} environments x {r['thetas']:5,d} θ = "
              f"{r['envs'] * r['thetas']:11,d} trajectories in {r['seconds']:6.1f} s "
              f"({r['envs'] * r['thetas'] / r['seconds']:9,.0f} traj/s), {r['gb']:.2f} GB, hash {r['hash']}")
    grid = rows[0]["seconds"]
    verdict = "met" if grid <= 120 else "NOT met"
    print(f"gridworld paper table: {grid:.1f} s (bar: at most 120 s on 2 cores) -> {verdict}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
