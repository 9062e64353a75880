"""Queue overhead: trajectories/s through Celery workers against the
planner's own throughput in one process, and the projected paper-table time.

    python bench/precompute.py [--chunks 4] [--rounds 3] [--workers 2] [--broker redis://127.0.0.1:6379/14]

Rounds alternate the two measurements on the same chunks (each Celery round
writes into a fresh directory, so nothing is skipped), so that load from other
processes on the machine falls on both alike; the load average is printed.

1. planner: ``plan_chunk`` on the selected chunks in this process, Numba using
   every core (its default), nothing written;
2. celery: the same chunks as ``precompute.table_chunk`` tasks (plan, write the
   content-addressed .npz, journal) on one ``celery worker --pool=prefork -c
   WORKERS`` process (1 Numba thread per child), from sending the group to the
   last result; the worker processes are warmed first (every pool child has loaded the
   compiled kernels), as they are after the first chunk of a real job;
3. the ratio celery / planner (bar: >= 0.90, at most 10 % lost to the queue),
   a bit-for-bit check of the chunks against the in-process results, the
   publish rate (assemble + hash, MB/s) and the projection for the paper preset
   on 1, 4 and 16 machines like this one.

The chunks are the paper preset's (32 environments x 1000 thetas), evenly
spaced over the grid so the four environment classes are all represented.
Every figure is measured in this run on this machine.
"""
from __future__ import annotations

import argparse
import hashlib
import math
import os
import shutil
import sys
import tempfile
import time
import uuid
from pathlib import Path

import numba
import numpy as np
from celery import Celery, Signature, group

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from precompute import procs, work  # noqa: E402  (no Django needed in this process)
from teaching.core.build import Preset, get_preset  # noqa: E402
from teaching.domains.driving.planner import plan_chunk  # noqa: E402


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--preset", default="paper")
    p.add_argument("--chunks", type=int, default=4, help="chunks per round (evenly spaced over the preset)")
    p.add_argument("--rounds", type=int, default=3, help="alternating planner / celery rounds")
    p.add_argument("--workers", type=int, default=2, help="worker processes (prefork -c)")
    p.add_argument("--broker", default=os.environ.get("BENCH_BROKER", "redis://127.0.0.1:6379/14"))
    p.add_argument("--out", help="scratch directory (default: a temporary one, removed)")
    return p.parse_args(argv)


def client(url):
    app = Celery("bench-precompute", broker=url, backend=url)
    app.conf.result_expires = 3600
    return app


def chunk_group(app, spec, picks, queue):
    return group(Signature("precompute.table_chunk", args=(None, spec, i, ids), immutable=True,
                           options={"queue": queue}, app=app) for i, ids in picks)


def warm_up(app, queue, workers, scratch) -> set:
    """Send tiny chunks until every pool child has run one (loaded the compiled kernels)."""
    spec = work.table_spec(Preset("bench-warmup", n_envs=64, n_thetas=8, chunk_size=1), scratch / "warmup")
    ids = work.chunk_ids(spec)
    seen, k = set(), 0
    while len(seen) < workers and k + 4 <= len(ids):
        picks = [(k + j, ids[k + j]) for j in range(4)]
        k += 4
        chunk_group(app, spec, picks, queue).apply_async().get(timeout=300)
        seen = {e["host"] for e in work.read_journal(spec["out"]) if e["event"] == "stored"}
    return seen


def publish_rate(out: Path, keys: list[str]) -> float:
    """MB/s of what publishing does per byte: read chunks, copy into memory maps, hash."""
    t0 = time.perf_counter()
    total = 0
    h = hashlib.sha256()
    for key in keys:
        with np.load(work.chunk_path(out, key)) as data:
            for name in ("controls", "features", "strategy", "d_euclid"):
                a = data[name]
                mm = np.lib.format.open_memmap(out / f".bench-{name}.npy", mode="w+", dtype=a.dtype, shape=a.shape)
                mm[:] = a
                mm.flush()
                h.update(np.ascontiguousarray(mm).view(np.uint8).reshape(-1))
                total += a.nbytes
                del mm
    for name in ("controls", "features", "strategy", "d_euclid"):
        (out / f".bench-{name}.npy").unlink(missing_ok=True)
    return total / 1e6 / (time.perf_counter() - t0), total / len(keys)


def fmt_h(seconds: float) -> str:
    return f"{seconds / 3600:.2f} h" if seconds >= 3600 else f"{seconds / 60:.1f} min"


def main(argv=None) -> int:
    args = parse_args(argv)
    preset = get_preset(args.preset)
    scratch = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench-precompute-"))
    scratch.mkdir(parents=True, exist_ok=True)
    specs = [work.table_spec(preset, scratch / f"table-{k}") for k in range(args.rounds)]
    spec = specs[0]
    all_ids = work.chunk_ids(spec)
    idx = np.unique(np.linspace(0, len(all_ids) - 1, args.chunks).round().astype(int))
    picks = [(int(i), all_ids[i]) for i in idx]
    n_traj = sum(len(ids) for _, ids in picks) * preset.n_thetas
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start; preset {preset.name}: "
          f"{len(all_ids)} chunks of {preset.chunk_size} envs x {preset.n_thetas} thetas; timing {len(picks)} "
          f"chunks = {n_traj:,} trajectories per round, {args.rounds} rounds (planner, then celery, alternating)")

    _, thetas, normalisers, _ = work._context(spec)
    plan_chunk(np.asarray(picks[0][1][:2]), thetas[:8], normalisers)  # load the compiled kernels

    queue = f"bench-{uuid.uuid4().hex[:8]}"
    env = {"CELERY_BROKER_URL": args.broker, "CELERY_RESULT_BACKEND": args.broker, "PRECOMPUTE_THREADS": "1",
           "VAR_DIR": str(scratch / "var"), "DATABASE_URL": f"sqlite:///{scratch / 'worker.sqlite3'}"}
    worker = procs.start_worker(queue, concurrency=args.workers, env=env, log_path=scratch / "worker.log")
    app = client(args.broker)
    t_plan = t_celery = busy = 0.0
    same, ratios, results = True, [], []
    try:
        procs.wait_ready(worker, timeout=120)
        seen = warm_up(app, queue, args.workers, scratch)
        for k, spec_k in enumerate(specs):
            # 1. the planner alone, one process, Numba on every core, nothing written
            t0 = time.perf_counter()
            local = {i: plan_chunk(np.asarray(ids), thetas, normalisers) for i, ids in picks}
            tp = time.perf_counter() - t0
            # 2. the same chunks through Celery (a fresh output directory: nothing is skipped)
            t0 = time.perf_counter()
            results = chunk_group(app, spec_k, picks, queue).apply_async().get(timeout=3600)
            tc = time.perf_counter() - t0
            assert all(r["computed"] for r in results)
            t_plan, t_celery, busy = t_plan + tp, t_celery + tc, busy + sum(r["seconds"] for r in results)
            ratios.append(tp / tc)
            print(f"  round {k + 1}: planner {tp:6.1f} s ({n_traj / tp:7,.0f}/s), celery {tc:6.1f} s "
                  f"({n_traj / tc:7,.0f}/s), ratio {tp / tc:.3f}, load {os.getloadavg()[0]:.2f}")
            # bit-for-bit: the workers' chunk files against the in-process results
            for r in results:
                with np.load(work.chunk_path(spec_k["out"], r["key"])) as data:
                    same &= all(np.array_equal(data[key], v) for key, v in local[r["index"]].items())
    finally:
        procs.stop_worker(worker)
        app.close()
    n_all = n_traj * args.rounds
    r_plan, r_celery = n_all / t_plan, n_all / t_celery
    print(f"planner, 1 process x {numba.get_num_threads()} Numba threads: {t_plan:7.1f} s  "
          f"{r_plan:8,.0f} trajectories/s")
    print(f"celery, {args.workers} worker processes x 1 thread ({args.broker.split(':')[0]} broker, "
          f"{len(seen)} children warmed): {t_celery:7.1f} s  {r_celery:8,.0f} trajectories/s")
    ratio = r_celery / r_plan
    lost = f"{100 * (1 - ratio):.1f} % lost" if ratio < 1 else f"nothing lost, {100 * (ratio - 1):.1f} % faster"
    print(f"ratio celery / planner: {ratio:.3f} ({lost}; bar: <= 10 % lost) "
          f"{'PASS' if ratio >= 0.9 else 'FAIL'}; per round {', '.join(f'{r:.3f}' for r in ratios)}")
    print(f"  in-task compute {busy:.1f} s over {args.workers} x {t_celery:.1f} s of worker time: "
          f"{100 * busy / (args.workers * t_celery):.1f} % busy; mean chunk {busy / (len(picks) * args.rounds):.1f} s "
          f"on one core")
    print(f"chunks identical to the in-process planner: {'yes' if same else 'NO'}")
    out = Path(specs[-1]["out"])

    # 3. projection for the paper preset: chunks are independent, so N machines with W worker
    # processes each finish in ceil(chunks / (N W)) rounds of one chunk's wall time per slot
    # (measured above, queue overhead included), then one machine publishes.
    paper = get_preset("paper")
    rate, chunk_bytes = publish_rate(out, [r["key"] for r in results])
    per_traj = paper.n_thetas * paper.chunk_size / (preset.n_thetas * preset.chunk_size)
    n_paper_chunks = math.ceil(paper.n_envs / paper.chunk_size)
    slot_wall = t_celery * args.workers / (len(picks) * args.rounds) * per_traj  # s per paper chunk per slot
    paper_bytes = n_paper_chunks * chunk_bytes * per_traj
    t_publish = paper_bytes / 1e6 / rate
    print(f"publish (read chunks, write memory maps, hash): {rate:,.0f} MB/s -> paper table "
          f"{paper_bytes / 1e9:.2f} GB in ~{t_publish / 60:.1f} min on one machine")
    print(f"projection, paper preset ({paper.n_envs:,} x {paper.n_thetas:,} = "
          f"{paper.n_envs * paper.n_thetas / 1e6:.1f} M trajectories, {n_paper_chunks} chunks of "
          f"{slot_wall:.1f} s per worker process), machines like this one ({args.workers} worker processes each):")
    for machines in (1, 4, 16):
        t_compute = math.ceil(n_paper_chunks / (machines * args.workers)) * slot_wall
        print(f"  {machines:2d} machine(s): compute {fmt_h(t_compute)} + publish {fmt_h(t_publish)} "
              f"= {fmt_h(t_compute + t_publish)}")
    if not args.out:
        shutil.rmtree(scratch, ignore_errors=True)
    return 0 if ratio >= 0.9 and same else 1


if __name__ == "__main__":
    sys.exit(main())
