"""A closed-loop condition on disk: what a web worker needs to decide and to draw.

A study job writes it once (:func:`write_pack`).  Every web worker maps the same files read-only
(:func:`load_pack`), so the paper table's 85 MB likelihood matrix is in memory once, however many
workers there are, and no web worker opens the 5 GB trajectory table::

    meta.json          the spec, the check questions, the table's content hash and domain, the shapes
    lik.npy            (M, N) float32 L_M(E, θ) of the spec's learner model, every table row
    check_lik.npy      (C, K, N) float32 P(k | θ, E) of each check question (closedloop.answer_likelihood,
                       answer_rows), padded with zero rows to the most answers of any check
    eligible.npy       (M,) bool, the rows examples may come from
    env_ids.npy        (M,) int64 environment ids; env_class.npy (M,) int8; star_cluster.npy (M,) int8
    star_states.npy    (M, T+1, S) float64 θ*'s trajectory in every environment: a training example's path

Files are written under temporary names and renamed, meta.json last, so a reader never maps half a pack.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .answers import Question
from .closedloop import ClosedLoop, ClosedLoopError, ClosedLoopSpec

PACK_VERSION = 1
ARRAYS = ("lik", "check_lik", "eligible", "env_ids", "env_class", "star_cluster", "star_states")


@dataclass(frozen=True)
class Pack:
    """A loaded pack: the condition's ClosedLoop (deciding) and θ*'s trajectories (drawing), by table row."""

    loop: ClosedLoop
    env_ids: np.ndarray
    env_class: np.ndarray
    star_cluster: np.ndarray
    star_states: np.ndarray
    meta: dict

    def row_of(self, env_id: int) -> int:
        hits = np.flatnonzero(self.env_ids == int(env_id))
        if not len(hits):
            raise ClosedLoopError(f"environment {env_id} is not in this closed-loop condition's table")
        return int(hits[0])


def write_pack(path, table, loop: ClosedLoop) -> str:
    """Write `loop` (built on `table`) and θ*'s trajectories to directory `path`; returns the table's hash."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ClosedLoopError(f"cannot write a closed-loop condition to {path}: {exc.strerror}") from None
    m, n = loop.lik.shape
    k = max((len(c) for c in loop.check_lik), default=0)  # a shown check's options vary: padded to the most
    star = table.theta_star_index
    arrays = {
        "lik": np.asarray(loop.lik, np.float32),
        "check_lik": (np.stack([np.pad(c, ((0, k - len(c)), (0, 0))) for c in loop.check_lik]).astype(np.float32)
                      if loop.checks else np.zeros((0, k, n), np.float32)),
        "eligible": loop.eligible,
        "env_ids": np.asarray(table.env_ids, np.int64),
        "env_class": np.asarray(table.env_class, np.int8),
        "star_cluster": np.asarray(table.strategy[:, star], np.int8),
        "star_states": np.asarray(table.states(np.arange(m), star), np.float64),
    }
    for name, array in arrays.items():
        tmp = path / f".{name}.tmp.npy"
        np.save(tmp, np.ascontiguousarray(array))
        os.replace(tmp, path / f"{name}.npy")
    meta = {"version": PACK_VERSION, "spec": loop.spec.as_dict(), "table_hash": table.meta.get("content_hash"),
            "domain": table.domain.name, "n_envs": m, "n_thetas": n,
            "checks": [{"env_index": q.env_index, "options": list(q.options), **({"shown": True} if q.shown else {})}
                       for q in loop.checks]}
    tmp = path / ".meta.json.tmp"
    tmp.write_text(json.dumps(meta, indent=1))
    os.replace(tmp, path / "meta.json")
    return meta["table_hash"]


def load_pack(path, expected_hash: str | None = None) -> Pack:
    """The pack at `path`, its arrays memory-mapped read-only; ClosedLoopError (one line) when it is
    missing, incomplete, of another version, or (given `expected_hash`) built on another table."""
    path = Path(path)
    try:
        meta = json.loads((path / "meta.json").read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        raise ClosedLoopError(f"no closed-loop condition at {path} (meta.json missing or unreadable)") from None
    if meta.get("version") != PACK_VERSION:
        raise ClosedLoopError(f"the closed-loop condition at {path} has version {meta.get('version')!r}, "
                              f"not {PACK_VERSION}: rebuild it")
    if expected_hash is not None and meta.get("table_hash") != expected_hash:
        raise ClosedLoopError(f"the closed-loop condition at {path} was built on table "
                              f"{str(meta.get('table_hash'))[:16]}, not {expected_hash[:16]}: rebuild it")
    try:
        a = {name: np.load(path / f"{name}.npy", mmap_mode="r") for name in ARRAYS}
    except (FileNotFoundError, ValueError) as exc:
        raise ClosedLoopError(f"the closed-loop condition at {path} is incomplete or corrupt: {exc}") from None
    if a["lik"].shape != (meta["n_envs"], meta["n_thetas"]):
        raise ClosedLoopError(f"the closed-loop condition at {path} is corrupt: lik has shape {a['lik'].shape}")
    checks = tuple(Question(int(q["env_index"]), tuple(int(o) for o in q["options"]), bool(q.get("shown")))
                   for q in meta["checks"])
    # each check's own answers: its options, and for a shown check the way none of them takes
    check_lik = [c[:len(q.options) + q.shown] for c, q in zip(a["check_lik"], checks, strict=True)]
    loop = ClosedLoop(ClosedLoopSpec.from_dict(meta["spec"]), a["lik"], checks, check_lik, a["eligible"])
    return Pack(loop, a["env_ids"], a["env_class"], a["star_cluster"], a["star_states"], meta)
