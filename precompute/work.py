"""The work itself, without Celery or the database: one chunk, and publishing.

A table job is described by a JSON-able *spec* (preset fields, output
directory, normalisers and the table identity computed by the launcher).
Every worker recomputes the thetas from (n, sampler, seed) and checks that
its identity matches the launcher's and that it runs the same teaching code
(a hash of every module of the package), so a machine with other world
constants, another numpy or another commit cannot add chunks to the table.

Chunk files are content-addressed (``<out>/chunks/<key>.npz``, key = hash of
the table identity and the chunk's environment ids) and written atomically
(unique temporary name, then ``os.replace``), so a chunk that exists is
complete and a re-run or re-delivered task skips it.

``<out>/build.log`` is an append-only journal (JSON lines: start, stored,
skipped, published) with host, pid and timings: the audit trail that shows
nothing stored was ever computed twice.
"""
from __future__ import annotations

import fcntl
import json
import os
import time
from dataclasses import asdict
from functools import cache, lru_cache
from pathlib import Path

import numpy as np

from teaching import api
from teaching.api import (
    Preset,
    TableError,
    TrajectoryTable,
    assemble,
    build_chunk,
    chunk_key,
    chunk_path,
    chunks_of,
    code_fingerprint,
    get_domain,
    table_identity,
)

from .procs import host_id


@cache
def domain_code(domain: str) -> str:
    """The source of teaching/core and `domain`'s package, hashed once per process when first
    needed (i.e. the code this process actually runs); every task checks it against the
    launcher's, so machines on different commits refuse instead of mixing chunks.  Per domain:
    an edit to another robot's code does not stop this one's builds."""
    return code_fingerprint(domain)


class ChunkError(RuntimeError):
    """A chunk task that cannot run: identity mismatch, unwritable output, missing chunks."""


@lru_cache(maxsize=8)
def _thetas(preset: Preset) -> np.ndarray:
    thetas = preset.thetas()
    thetas.setflags(write=False)
    return thetas


def preset_of(spec: dict) -> Preset:
    return Preset(**spec["preset"])


def check_writable(out: Path) -> None:
    try:
        api.check_writable(out)
    except TableError as exc:  # a task error, not a table error, to the job page
        raise ChunkError(str(exc)) from None


def table_spec(preset: Preset, out) -> dict:
    """Everything a worker needs to build any chunk of `preset`'s table in `out`."""
    out = Path(out).resolve()
    thetas = _thetas(preset)
    normalisers = get_domain(preset.domain).default_normalisers()
    env_ids = preset.env_ids()
    return {
        "preset": asdict(preset),
        "out": str(out),
        "normalisers": [float(v) for v in normalisers],  # JSON floats round-trip exactly
        "identity": table_identity(preset, thetas, normalisers),
        "code": domain_code(preset.domain),
        "n_envs": int(len(env_ids)),
        "n_chunks": len(chunks_of(env_ids, preset.chunk_size)),
    }


def chunk_ids(spec: dict) -> list[list[int]]:
    preset = preset_of(spec)
    return [[int(e) for e in c] for c in chunks_of(preset.env_ids(), preset.chunk_size)]


def _context(spec: dict):
    preset = preset_of(spec)
    thetas = _thetas(preset)
    normalisers = np.array(spec["normalisers"], dtype=np.float64)
    identity = table_identity(preset, thetas, normalisers)
    ours = domain_code(preset.domain)
    if spec.get("code", ours) != ours:
        raise ChunkError(
            f"this worker ({host_id()}) runs other planner code than the launcher "
            f"(teaching/core + {preset.domain} fingerprint {ours} != {spec['code']}); deploy one commit "
            f"everywhere and restart the workers")
    if identity != spec["identity"]:
        diff = sorted(k for k in identity if identity.get(k) != spec["identity"].get(k))
        raise ChunkError(
            f"this worker ({host_id()}) computes another table identity than the launcher "
            f"(differs in: {', '.join(diff)}); check that all machines run the same code and numpy")
    return preset, thetas, normalisers, identity


def journal(out, event: str, **fields) -> None:
    """Append one JSON line to <out>/build.log (a single O_APPEND write: lines never interleave)."""
    line = json.dumps({"event": event, "host": host_id(), "time": round(time.time(), 3), **fields}) + "\n"
    fd = os.open(Path(out) / "build.log", os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line.encode())
    finally:
        os.close(fd)


def read_journal(out) -> list[dict]:
    path = Path(out) / "build.log"
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def compute_chunk(spec: dict, env_ids) -> dict:
    """Build one chunk unless it is stored (``teaching.core.build.build_chunk``, whose
    temporary names are unique per host, process and call, so a re-delivery on a
    shared filesystem never shares one), journalling it.  Returns key, computed,
    seconds, trajectories."""
    out = Path(spec["out"])
    preset, thetas, normalisers, identity = _context(spec)
    env_ids = np.asarray(env_ids, dtype=np.int64)
    key = chunk_key(identity, env_ids)
    path = chunk_path(out, key)
    n_traj = int(len(env_ids) * len(thetas))
    if path.exists():
        journal(out, "skipped", key=key)
        return {"key": key, "computed": False, "seconds": 0.0, "trajectories": 0}
    check_writable(out)
    journal(out, "start", key=key)
    t0 = time.perf_counter()
    build_chunk(out, identity, env_ids, thetas, normalisers, preset.domain)
    seconds = time.perf_counter() - t0
    journal(out, "stored", key=key, seconds=round(seconds, 3), trajectories=n_traj)
    return {"key": key, "computed": True, "seconds": seconds, "trajectories": n_traj}


def missing_chunks(spec: dict) -> list[int]:
    preset, thetas, normalisers, identity = _context(spec)
    return [i for i, ids in enumerate(chunk_ids(spec))
            if not chunk_path(spec["out"], chunk_key(identity, np.asarray(ids, np.int64))).exists()]


def _published(out: Path, preset: Preset, thetas, env_ids) -> TrajectoryTable | None:
    """The table already published in `out` for exactly this preset, Θ and environments, or None."""
    if not (out / "meta.json").exists():
        return None
    try:
        table = TrajectoryTable.load(out)  # verifies the content hash
    except TableError:
        return None
    same = (table.meta.get("preset") == preset.name and table.meta.get("seed") == preset.seed
            and table.meta.get("sampler") == preset.sampler and np.array_equal(table.thetas, thetas)
            and np.array_equal(table.env_ids, env_ids))
    return table if same else None


def publish(spec: dict) -> dict:
    """Check that every chunk is stored, assemble the table, verify it and publish meta.json.

    Publishing holds an exclusive lock on <out>/.publish.lock, so two publishers (a job
    relaunched while its publish step runs, a re-delivered message) never interleave their
    temporary files; the second one finds the table published and only verifies it.
    """
    out = Path(spec["out"])
    preset, thetas, normalisers, identity = _context(spec)
    missing = missing_chunks(spec)
    if missing:
        raise ChunkError(f"{len(missing)} of {spec['n_chunks']} chunks are not stored "
                         f"(first missing: chunk {missing[0]}); retry the job to compute them")
    t0 = time.perf_counter()
    env_ids = preset.env_ids()
    with open(out / ".publish.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        table = _published(out, preset, thetas, env_ids)
        reused = table is not None
        if table is None:
            table = assemble(out, preset, identity, env_ids, thetas, normalisers)  # verifies the hash on load
        d_min = float(table.d_reward().min())
        if d_min < 0:
            raise TableError(f"assembled table has d_reward {d_min:.3g} < 0: the cross-theta step did not hold")
        info = {"path": str(out), "content_hash": table.meta["content_hash"], "n_envs": table.n_envs,
                "n_thetas": table.n_thetas, "min_d_reward": d_min, "already_published": reused,
                "assemble_seconds": round(time.perf_counter() - t0, 3)}
        # still under the lock: the journal's order is the order the publishers held it
        journal(out, "verified" if reused else "published", content_hash=info["content_hash"])
    return info


def load_table(path) -> TrajectoryTable:
    return TrajectoryTable.load(path)
