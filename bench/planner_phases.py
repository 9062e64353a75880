"""Where a chunk's planning time goes: the planner's phases timed in one process with one thread.

    python bench/planner_phases.py [--stride 160] [--code DIR]

Plans every --stride-th chunk of the `paper` preset (as bench/paper_sample.py picks them) once to
warm up and once timed, with the planner's batch calls wrapped in timers: penalised projected
Newton (`solve`), the exact step's SQP (`solve_constrained`), the hand-overs' pool rewards
(`_pool_best`), features, strategy labels and limit checks; the rest is NumPy glue.  One thread,
so the phases add up to the total; whole-build speed is bench/paper_sample.py's job.  It prints the
planner's own counters too (solves, Newton and SQP iterations) and a hash of the outputs, which a
change meant to keep the same bits must leave as it was.
"""
from __future__ import annotations

import argparse
import collections
import hashlib
import sys
import time
from pathlib import Path

WRAPPED = {"solve": "newton", "solve_constrained": "sqp", "_pool_best": "pool rewards",
           "raw_features": "features", "strategy_labels": "labels", "limit_excess": "limit checks"}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--stride", type=int, default=160, help="plan every STRIDE-th chunk (default 160: 4 of 663)")
    parser.add_argument("--code", default=str(Path(__file__).resolve().parents[1]),
                        help="the checkout whose teaching package plans (default: this one)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(Path(args.code).resolve()))
    import numba  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415
    from paper_sample import planner_modules, sample_chunks  # noqa: PLC0415  (bench/ is this script's sys.path[0])

    build, features, planner = planner_modules()  # today's modules, or an old checkout's flat ones

    numba.set_num_threads(1)
    seconds = collections.Counter()

    def timed(name, fn):
        def wrapper(*a, **k):
            start = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                seconds[name] += time.process_time() - start
        return wrapper

    for attr, name in WRAPPED.items():
        if hasattr(planner, attr):
            setattr(planner, attr, timed(name, getattr(planner, attr)))
    preset, chunks = sample_chunks(build, args.stride)
    thetas, normalisers = preset.thetas(), features.default_normalisers()
    planner.plan_chunk(chunks[0][:2], thetas, normalisers)  # compile or load the kernels
    seconds.clear()
    stats, digest = {}, hashlib.sha256()
    start = time.process_time()
    for chunk in chunks:
        out = planner.plan_chunk(chunk, thetas, normalisers, stats=stats)
        for key in sorted(out):
            digest.update(np.ascontiguousarray(out[key]).tobytes())
    total = time.process_time() - start
    print(f"planner {planner.PLANNER_VERSION} from {args.code}: {len(chunks)} chunks, one thread, "
          f"{total:.2f} s CPU; outputs sha256 {digest.hexdigest()[:16]}")
    for name, s in seconds.most_common():
        print(f"  {name:13s} {s:7.2f} s  {100 * s / total:5.1f} %")
    other = total - sum(seconds.values())
    print(f"  {'other':13s} {other:7.2f} s  {100 * other / total:5.1f} %")
    print("  counters:", ", ".join(f"{k} {v:,}" for k, v in stats.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
