"""The trajectory table: the optimal trajectory of every (environment, theta), for one domain.

Layout on disk (a directory); M environments, N thetas, D features::

    meta.json                  identity: domain, preset, sampler, seed, world fingerprint,
                               normalisers, shapes, chunk list, content hash
    thetas.npy                 (N, D) float64, thetas[0] is theta_star
    env_ids.npy                (M,) int64
    controls.npy               (M, N, *trajectory_shape) the domain's encoding of each trajectory
    features.npy               (M, N, D) float64 normalised features
    strategy.npy               (M, N) int8 cluster 0..C-1, C = no strategy
    d_euclid.npy               (M, N) float32 distance of each theta's trajectory to theta_star's

The content hash covers every array byte and the identity fields, so a table that was altered
(or built under other world constants) is refused.  The domain's name is not among the hashed
fields (so tables built before domains kept their hashes); the world fingerprint is,
and it is the domain's own, so a table cannot pass for another domain's.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from .domain import Domain, get_domain, register_carried
from .rewards import reward

ARRAYS = ("thetas", "env_ids", "controls", "features", "strategy", "d_euclid")
FORMAT_VERSION = 1


class TableError(ValueError):
    """A table that cannot be used: missing, corrupt, or built under other constants."""


@dataclass
class TrajectoryTable:
    thetas: np.ndarray
    env_ids: np.ndarray
    controls: np.ndarray
    features: np.ndarray
    strategy: np.ndarray
    d_euclid: np.ndarray
    normalisers: np.ndarray
    meta: dict = field(default_factory=dict)

    theta_star_index = 0

    @property
    def n_envs(self) -> int:
        return len(self.env_ids)

    @property
    def n_thetas(self) -> int:
        return len(self.thetas)

    @property
    def theta_star(self) -> np.ndarray:
        return self.thetas[0]

    @property
    def domain(self) -> Domain:
        """The domain the table was built in (meta.json's "domain"; tables from before domains
        name none and are the default domain's)."""
        return get_domain(self.meta.get("domain"))

    @cached_property
    def row_of(self) -> dict[int, int]:
        """{environment id: its table row}, built once per table (a KeyError names an id not in it)."""
        return {int(e): i for i, e in enumerate(np.asarray(self.env_ids))}

    @cached_property
    def memo(self) -> dict:
        """Values computed from this table alone, kept while the object lives (its arrays do not change once
        loaded): {(what, *arguments): value}.  A test set's candidate environments are asked for by each
        difficulty level and by the designer's counts; each is worked out once."""
        return {}

    @property
    def env_class(self) -> np.ndarray:
        """(M,) int8 class of each environment (index into the domain's class_names)."""
        return self.domain.environment_class(np.asarray(self.env_ids))

    def rewards(self) -> np.ndarray:
        """(M, N) reward of each theta's own trajectory under that theta."""
        return reward(self.features, self.thetas)

    def d_reward(self) -> np.ndarray:
        """(M, N) theta.phi(xi^theta) - theta.phi(xi^theta*), >= 0 after the cross-theta step."""
        return self.rewards() - reward(self.features[:, :1], self.thetas)

    def states(self, env_index, theta_index) -> np.ndarray:
        """Robot states (..., T+1, S) of the stored trajectories (rebuilt by the domain)."""
        return self.domain.states(self.controls[env_index, theta_index])

    # --- persistence -------------------------------------------------------
    def save(self, path, arrays=ARRAYS) -> str:
        """Write the table to directory `path`; returns the content hash.

        Each file is written to a temporary name and renamed, and meta.json
        (with the hash) goes last, so a reader never sees a half-written table.
        `arrays` names the arrays to (re)write; the builder passes only the
        small ones because it has already put the large ones in place.
        """
        path = Path(path)
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise TableError(f"cannot write table to {path}: {exc.strerror}") from exc
        if not os.access(path, os.W_OK):
            raise TableError(f"cannot write table to {path}: not writable")
        for name in arrays:
            tmp = path / f".{name}.tmp.npy"
            np.save(tmp, np.ascontiguousarray(getattr(self, name)))
            os.replace(tmp, path / f"{name}.npy")
        meta = dict(self.meta)
        meta.update(
            domain=self.domain.name,
            format_version=FORMAT_VERSION,
            world=self.domain.fingerprint(),
            normalisers=[float(v) for v in self.normalisers],
            shape={"envs": self.n_envs, "thetas": self.n_thetas},
        )
        meta["content_hash"] = content_hash(self, meta)
        self.meta = meta
        tmp = path / ".meta.json.tmp"
        tmp.write_text(json.dumps(meta, indent=2, sort_keys=True))
        os.replace(tmp, path / "meta.json")
        return meta["content_hash"]

    @classmethod
    def load(cls, path, mmap: bool = True, verify: bool = True, expected_hash: str | None = None) -> TrajectoryTable:
        """Load a saved table (arrays memory-mapped read-only by default).

        Raises TableError for a missing table, one built under other world
        constants, (verify=True) one whose bytes do not match its hash, or one
        whose recorded hash is not `expected_hash`.  ``verify=False,
        expected_hash=h`` is the cheap load for a table someone verified as h
        already (a study job's launcher): re-hashing a paper table reads 2.65 GB,
        comparing meta.json's hash reads nothing, and a table rebuilt or replaced
        since is still refused (its meta.json carries another hash).
        """
        path = Path(path)
        try:
            meta = json.loads((path / "meta.json").read_text())
        except FileNotFoundError:
            raise TableError(f"no trajectory table at {path} (meta.json missing)") from None
        if expected_hash is not None and meta.get("content_hash") != expected_hash:
            raise TableError(
                f"table at {path} (hash {str(meta.get('content_hash'))[:16]}) is not the one that was verified "
                f"(hash {str(expected_hash)[:16]}): it was rebuilt or replaced since")
        try:
            register_carried(path, meta)
            domain = get_domain(meta.get("domain"))
        except ValueError as exc:
            raise TableError(f"table at {path}: {exc}") from None
        if meta.get("world") != domain.fingerprint():
            raise TableError(
                f"table at {path} was built with other world constants "
                f"({meta.get('world')} != {domain.fingerprint()} of domain {domain.name!r}); rebuild it")
        try:
            arrays = {n: np.load(path / f"{n}.npy", mmap_mode="r" if mmap else None) for n in ARRAYS}
        except (FileNotFoundError, ValueError) as exc:
            raise TableError(f"table at {path} is incomplete or corrupt: {exc}") from None
        table = cls(**arrays, normalisers=np.array(meta["normalisers"]), meta=meta)
        if verify and content_hash(table, meta) != meta.get("content_hash"):
            raise TableError(f"table at {path} does not match its content hash: it was altered or is corrupt")
        return table


def register_table_robot(path) -> str | None:
    """Register the robot the table at `path` carries, if it carries one (a table made by import-table), so that
    a process that looks a robot up by name before it loads the table (the site, a worker) finds it; returns
    the name of the table's robot.  TableError (one line) for a table that cannot be read or whose robot cannot
    be registered."""
    path = Path(path)
    try:
        meta = json.loads((path / "meta.json").read_text())
        register_carried(path, meta)
    except (OSError, ValueError) as exc:
        raise TableError(f"table at {path}: {exc}") from None
    return meta.get("domain")


IDENTITY = ("preset", "sampler", "seed", "world", "normalisers", "format_version")


def content_hash(table: TrajectoryTable, meta: dict) -> str:
    """sha256 over the identity fields and every array's dtype, shape and bytes."""
    h = hashlib.sha256()
    h.update(json.dumps({k: meta.get(k) for k in IDENTITY}, sort_keys=True).encode())
    for name in ARRAYS:
        a = getattr(table, name)
        h.update(f"{name}{a.dtype.str}{a.shape}".encode())
        for block in _blocks(a):
            h.update(block)
    return h.hexdigest()


def _blocks(a: np.ndarray, step: int = 1 << 26):
    """The array's bytes in 64 MB blocks.  A memory-mapped array is read from its
    file instead of through the map, so hashing a 3 GB table does not make 3 GB
    of it resident in this process."""
    if isinstance(a, np.memmap) and a.filename and a.flags.c_contiguous and a.base is not None:
        with open(a.filename, "rb") as f:
            f.seek(a.offset)
            left = a.nbytes
            while left:
                block = f.read(min(step, left))
                if not block:
                    raise TableError(f"{a.filename} is shorter than its header says")
                yield block
                left -= len(block)
        return
    flat = np.ascontiguousarray(a).reshape(-1).view(np.uint8)
    for i in range(0, len(flat), step):
        yield flat[i:i + step]
