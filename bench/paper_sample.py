"""Plan an even sample of the `paper` preset's chunks (every --stride-th, across the whole grid) with the
planner of a given checkout, and print the time and a hash of every output array.

    python bench/paper_sample.py [--stride 40] [--jobs 2] [--code DIR]

A full paper build takes 25-50 minutes on a 2-core machine, and machines differ by more than the
changes one wants to measure (planner 10's build took 24.0 min on one; on another it ran at half
that rate).  So speed is compared side by side on one machine: run this
alternately with --code pointing at two checkouts (`git worktree add /tmp/v8 <commit>`), under
`/usr/bin/time -v`, several times each, and quote the median ratio.  --jobs 1 plans in this process
with every core as a Numba thread (how builds ran before `build --jobs`); --jobs N in N spawned
processes with cores // N threads each (`python -m teaching build --jobs N`).  The hash is the same
for any --jobs, and for two checkouts whose planners return the same bits.
"""
from __future__ import annotations

import argparse
import hashlib
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path


def _digest(out: dict) -> str:
    import numpy as np  # noqa: PLC0415

    return hashlib.sha256(b"".join(np.ascontiguousarray(out[k]).tobytes() for k in sorted(out))).hexdigest()


def planner_modules():
    """(build, features, planner) modules of the checkout on sys.path: today's layout, or the flat
    one of planners up to 8 (teaching/build.py, ...), so that old checkouts can be compared too."""
    import importlib  # noqa: PLC0415

    try:
        return tuple(importlib.import_module(m) for m in (
            "teaching.core.build", "teaching.domains.driving.features", "teaching.domains.driving.planner"))
    except ModuleNotFoundError:
        return tuple(importlib.import_module(f"teaching.{m}") for m in ("build", "features", "planner"))


def sample_chunks(build, stride: int):
    """(the paper preset, its every stride-th chunk from the middle of the first stride on): the
    even sample across the grid that this benchmark and bench/planner_phases.py plan."""
    preset = build.PRESETS["paper"]
    return preset, build.chunks_of(preset.env_ids(), preset.chunk_size)[stride // 2::stride]


def _plan(args) -> str:
    chunk, thetas, normalisers, threads = args
    import numba  # noqa: PLC0415

    plan_chunk = planner_modules()[2].plan_chunk
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    return _digest(plan_chunk(chunk, thetas, normalisers))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--stride", type=int, default=40, help="plan every STRIDE-th chunk (default 40: 17 of 663)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (1: this process, threads)")
    parser.add_argument("--code", default=str(Path(__file__).resolve().parents[1]),
                        help="the checkout whose teaching package plans (default: this one)")
    args = parser.parse_args(argv)
    if args.stride < 1 or args.jobs < 1:
        parser.error("--stride and --jobs must be at least 1")
    sys.path.insert(0, str(Path(args.code).resolve()))  # spawned workers inherit sys.path
    build, features, planner = planner_modules()
    PLANNER_VERSION, plan_chunk = planner.PLANNER_VERSION, planner.plan_chunk

    preset, chunks = sample_chunks(build, args.stride)
    thetas, normalisers = preset.thetas(), features.default_normalisers()
    start = time.perf_counter()
    if args.jobs == 1:
        digests = [_digest(plan_chunk(c, thetas, normalisers)) for c in chunks]
    else:
        threads = max(1, (os.cpu_count() or 1) // args.jobs)
        with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            digests = list(pool.map(_plan, [(c, thetas, normalisers, threads) for c in chunks]))
    seconds = time.perf_counter() - start
    n_envs = sum(len(c) for c in chunks)
    print(f"planner {PLANNER_VERSION} from {args.code}: {len(chunks)} chunks ({n_envs} environments x "
          f"{len(thetas)} theta) in {seconds:.1f} s with --jobs {args.jobs}; whole paper table at this rate "
          f"{seconds * preset.n_envs / n_envs / 60:.1f} min; outputs sha256 "
          f"{hashlib.sha256(''.join(digests).encode()).hexdigest()[:16]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
