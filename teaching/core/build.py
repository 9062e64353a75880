"""Building a trajectory table: presets, chunks, resume, assembly (DESIGN §4).

A build is split into chunks of environments (the unit of work of a Celery
task later).  Each chunk's result is written atomically to
``<out>/chunks/<key>.npz`` where the key hashes the table identity and the
chunk's environment ids, so a re-run skips finished chunks and yields the same
bytes.  Assembly writes the final arrays through memory maps, so peak memory
is a few chunks, not the table.
"""
from __future__ import annotations

import hashlib
import json
import multiprocessing
import os
import secrets
import socket
import time
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .candidates import sample_thetas
from .domain import domain_names, get_domain
from .table import TableError, TrajectoryTable

CORE_DIR = Path(__file__).resolve().parent


def source_files(root: Path = CORE_DIR) -> list[Path]:
    """Every module (.py file) under `root`, sorted by relative path."""
    root = Path(root)
    # hidden names are editors' lock and swap files, never modules
    files = (p for p in root.rglob("*.py") if "__pycache__" not in p.parts and not p.name.startswith("."))
    return sorted(files, key=lambda p: p.relative_to(root).as_posix())


def code_fingerprint(domain: str | None = None, roots: tuple[Path, ...] | None = None) -> str:
    """16 hex digits of sha256 over every module that can decide a chunk's bytes in `domain`
    (default: the default domain): teaching/core and the domain's own package, each module's
    path (relative to its root) and source.

    Whole packages, not a hand-kept list of the modules that matter: a module added later is
    covered without anyone remembering to list it.  Per domain, so an edit to one robot does not
    make workers of another refuse to share its tables.  A domain that uses shared code outside its
    package names it in ``code_roots`` (teaching.core.base.BaseDomain), so an edit there is covered
    too.  `roots` replaces the packages (tests)."""
    if roots is None:
        d = get_domain(domain)
        roots = (CORE_DIR, *map(Path, d.code_roots))
    h = hashlib.sha256()
    for root in map(Path, roots):
        for path in source_files(root):
            h.update(f"{root.name}/{path.relative_to(root).as_posix()}".encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


@dataclass(frozen=True)
class Preset:
    """What to build: n_envs environments (the whole set when n_envs reaches the domain's count,
    else a stratified sample) x n_thetas objectives, θ* first and the rest drawn by `sampler`.
    domain and theta_star default to the default domain's (None: filled in on creation)."""

    name: str
    n_envs: int
    n_thetas: int
    sampler: str = "log-uniform"
    seed: int = 0
    chunk_size: int = 32
    theta_star: tuple | None = None  # thetas[0]; in the identity via thetas_sha
    domain: str | None = None

    def __post_init__(self):  # from JSON (a Celery job's spec) it arrives as a list, or without domain
        domain = get_domain(self.domain)
        object.__setattr__(self, "domain", domain.name)
        star = domain.theta_star if self.theta_star is None else self.theta_star
        object.__setattr__(self, "theta_star", domain.parse_theta_star(star))

    def thetas(self) -> np.ndarray:
        """The candidate objectives Theta (n_thetas, D), theta* first."""
        return sample_thetas(self.n_thetas, self.sampler, self.seed, theta_star=self.theta_star)

    def env_ids(self) -> np.ndarray:
        domain = get_domain(self.domain)
        if self.n_envs >= domain.n_environments:
            return np.arange(domain.n_environments)
        return domain.stratified_sample(self.n_envs, seed=self.seed)


def all_presets() -> dict[str, Preset]:
    """Every registered domain's presets by name (names are unique across domains)."""
    out = {}
    for name in domain_names():
        for preset in get_domain(name).presets:
            if preset.name in out:
                raise ValueError(f"preset name {preset.name!r} is used by two domains")
            out[preset.name] = preset
    return out


class _Presets(Mapping):
    """PRESETS["demo"]: :func:`all_presets`, read when used (domains register after this module loads)."""

    def __getitem__(self, name: str) -> Preset:
        return all_presets()[name]

    def __iter__(self):
        return iter(all_presets())

    def __len__(self) -> int:
        return len(all_presets())


PRESETS: Mapping[str, Preset] = _Presets()


def customised(preset: Preset, **changes) -> Preset:
    """`preset` with some of n_envs, n_thetas, sampler, seed, theta_star changed (None: unchanged).

    A changed environment set or Theta gets its own name (part of the table's identity and the
    default output directory): ``demo-1200x200-log-uniform-s0`` plus ``-star<hash>`` for another theta*.
    """
    if changes.get("theta_star") is not None:
        changes["theta_star"] = get_domain(preset.domain).parse_theta_star(changes["theta_star"])
    changes = {k: v for k, v in changes.items() if v is not None and v != getattr(preset, k)}
    if not changes:
        return preset
    p = replace(preset, **changes)
    name = f"{preset.name}-{p.n_envs}x{p.n_thetas}-{p.sampler}-s{p.seed}"
    if p.theta_star != all_presets().get(preset.name, preset).theta_star:
        name += "-star" + hashlib.sha256(json.dumps(p.theta_star).encode()).hexdigest()[:6]
    return replace(p, name=name)


def get_preset(name: str) -> Preset:
    presets = all_presets()
    try:
        return presets[name]
    except KeyError:
        raise ValueError(f"unknown preset {name!r}; choose one of {', '.join(presets)}") from None


def chunk_key(identity: dict, env_ids: np.ndarray) -> str:
    h = hashlib.sha256(json.dumps(identity, sort_keys=True).encode())
    h.update(np.ascontiguousarray(env_ids, dtype=np.int64).tobytes())
    return h.hexdigest()[:24]


def table_identity(preset: Preset, thetas: np.ndarray, normalisers: np.ndarray) -> dict:
    domain = get_domain(preset.domain)
    return {
        "preset": preset.name, "sampler": preset.sampler, "seed": preset.seed,
        "world": domain.fingerprint(), "normalisers": [float(v) for v in normalisers],
        "thetas_sha": hashlib.sha256(np.ascontiguousarray(thetas).tobytes()).hexdigest()[:16],
        "planner": domain.planner_identity(),
    }


def chunks_of(env_ids: np.ndarray, size: int) -> list[np.ndarray]:
    return [env_ids[i:i + size] for i in range(0, len(env_ids), size)]


def chunk_path(out, key: str) -> Path:
    return Path(out) / "chunks" / f"{key}.npz"


def build_chunk(out: Path, identity: dict, env_ids, thetas, normalisers, domain: str | None = None) -> tuple[str, bool]:
    """Compute one chunk of `domain` (None: the default one) unless it is already stored.
    Returns (key, computed)."""
    key = chunk_key(identity, env_ids)
    path = chunk_path(out, key)
    if path.exists():
        return key, False
    result = get_domain(domain).plan_chunk(np.asarray(env_ids), thetas, normalisers)
    path.parent.mkdir(parents=True, exist_ok=True)
    # unique across machines sharing the chunk directory, not just across processes
    tmp = path.with_name(f".{key}.{socket.gethostname()}.{os.getpid()}.{secrets.token_hex(4)}.tmp.npz")
    np.savez(tmp, env_ids=np.asarray(env_ids), **result)
    os.replace(tmp, path)  # atomic: a killed worker leaves no half chunk behind
    return key, True


def check_writable(out: Path) -> None:
    """Create `out`/chunks and prove a file can be written there, or raise TableError.

    The probe's name is unique so machines sharing the directory never race on it."""
    try:
        (out / "chunks").mkdir(parents=True, exist_ok=True)
        probe = out / f".write-probe.{socket.gethostname()}.{os.getpid()}.{secrets.token_hex(4)}"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise TableError(f"cannot write to {out}: {exc.strerror or exc}") from None


def build_table(preset: Preset, out, progress=None, jobs: int = 1) -> TrajectoryTable:
    """Build (or resume building) the preset's table in directory `out`.

    progress: optional callable(done_envs, total_envs) after each chunk.  jobs: worker processes, each
    planning whole chunks with cores // jobs Numba threads (1: this process, every core).  The table is
    the same whatever `jobs` is (each chunk's content depends on its environments alone); two processes
    on two cores are faster than two threads in one, whose serial parts (hand-overs, labels) leave a
    core idle.
    """
    if jobs < 1:
        raise ValueError(f"jobs must be at least 1, got {jobs}")
    out = Path(out)
    check_writable(out)
    thetas = preset.thetas()
    normalisers = get_domain(preset.domain).default_normalisers()
    identity = table_identity(preset, thetas, normalisers)
    env_ids = preset.env_ids()
    chunks = chunks_of(env_ids, preset.chunk_size)
    done = 0
    if jobs == 1:
        for chunk in chunks:
            build_chunk(out, identity, chunk, thetas, normalisers, preset.domain)
            done += len(chunk)
            if progress:
                progress(done, len(env_ids))
    else:
        # spawned, not forked: a child must not inherit a Numba thread pool this process may have started
        threads = max(1, (os.cpu_count() or 1) // jobs)
        with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"),
                                 initializer=_worker_threads, initargs=(threads,)) as pool:
            sizes = {pool.submit(build_chunk, out, identity, chunk, thetas, normalisers, preset.domain): len(chunk)
                     for chunk in chunks}
            try:
                for future in as_completed(sizes):
                    future.result()  # a chunk's error stops the build, with its traceback
                    done += sizes[future]
                    if progress:
                        progress(done, len(env_ids))
            except BaseException:
                pool.shutdown(cancel_futures=True)
                raise
    return assemble(out, preset, identity, env_ids, thetas, normalisers)


def _worker_threads(n: int) -> None:
    import numba  # noqa: PLC0415  (in the spawned child only)

    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))


def assemble(out: Path, preset: Preset, identity: dict, env_ids, thetas, normalisers) -> TrajectoryTable:
    """Concatenate the stored chunks into the table's memory-mapped arrays and publish it."""
    domain = get_domain(preset.domain)
    M, N, D = len(env_ids), len(thetas), len(domain.feature_names)
    shapes = {"controls": ((M, N, *domain.trajectory_shape), domain.trajectory_dtype),
              "features": ((M, N, D), np.float64),
              "strategy": ((M, N), np.int8), "d_euclid": ((M, N), np.float32)}
    # Create each .npy with its header, then write chunk rows with plain file
    # writes: the data goes through the page cache, not this process's memory.
    files, offsets = {}, {}
    for name, (shape, dt) in shapes.items():
        arr = np.lib.format.open_memmap(out / f".{name}.build.npy", mode="w+", dtype=dt, shape=shape)
        offsets[name] = arr.offset
        del arr
        files[name] = open(out / f".{name}.build.npy", "r+b")
    row = 0
    try:
        for chunk in chunks_of(env_ids, preset.chunk_size):
            with np.load(chunk_path(out, chunk_key(identity, chunk))) as data:
                if not np.array_equal(data["env_ids"], chunk):
                    raise TableError(f"chunk for environments {chunk[0]}..{chunk[-1]} does not match its key")
                for name, (shape, dt) in shapes.items():
                    block = np.ascontiguousarray(data[name], dtype=dt)
                    if block.shape != (len(chunk),) + shape[1:]:
                        raise TableError(f"chunk {name} has shape {block.shape}, expected {(len(chunk),) + shape[1:]}")
                    f = files[name]
                    f.seek(offsets[name] + row * block[0].nbytes)
                    f.write(block.tobytes())
            row += len(chunk)
    finally:
        for f in files.values():
            f.close()
    for name in shapes:
        os.replace(out / f".{name}.build.npy", out / f"{name}.npy")
    table = TrajectoryTable(
        thetas=thetas, env_ids=np.asarray(env_ids, np.int64), normalisers=normalisers,
        meta={"domain": domain.name, "preset": preset.name, "sampler": preset.sampler, "seed": preset.seed,
              "theta_star": [float(v) for v in thetas[0]], "planner": identity["planner"],
              "built_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())},
        **{name: np.load(out / f"{name}.npy", mmap_mode="r") for name in shapes},
    )
    table.save(out, arrays=("thetas", "env_ids"))
    return TrajectoryTable.load(out)
