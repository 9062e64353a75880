"""Trajectory table persistence (DESIGN §4): bit-exact round trip, content hash, refusal of altered or
foreign tables, resumable content-addressed chunks, unwritable outputs."""
import json
import os
import shutil
import subprocess
import sys
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from teaching.core.build import PRESETS, build_chunk, build_table, chunk_key, chunks_of, table_identity
from teaching.core.candidates import sample_thetas
from teaching.core.table import ARRAYS, TableError, TrajectoryTable, content_hash
from teaching.domains.driving.domain import DOMAIN as DRIVING
from teaching.domains.driving.environments import stratified_sample
from teaching.domains.driving.features import default_normalisers
from teaching.domains.driving.world import THETA_STAR, WORLD, world_fingerprint
from tests.builds import (
    NUMPY_AVX512,
    OTHER_CPU_NUMBA_CACHE,
    OTHER_CPU_TINY_TABLE,
    build_tiny_as_other_cpu,
    other_cpu_env,
    wait_build,
)
from tests.conftest import built_once

TINY = PRESETS["tiny"]


@pytest.fixture(scope="module")
def built(tiny_table):
    """The run's shared `tiny` table (read only: a test that alters one alters a copy_of it)."""
    return tiny_table, TrajectoryTable.load(tiny_table)


def copy_of(built, tmp_path):
    dst = tmp_path / "copy"
    shutil.copytree(built[0], dst)
    return dst


def file_bytes(path):
    return {p.name: p.read_bytes() for p in sorted(Path(path).glob("*.npy"))}


def test_tiny_table_contents(built):
    out, table = built
    assert (table.n_envs, table.n_thetas) == (48, 24)
    np.testing.assert_array_equal(table.thetas, sample_thetas(24, "log-uniform", 0, theta_star=THETA_STAR))
    np.testing.assert_array_equal(table.theta_star, THETA_STAR)
    np.testing.assert_array_equal(table.env_ids, stratified_sample(48, seed=0))
    np.testing.assert_array_equal(table.normalisers, default_normalisers())
    assert table.meta["preset"] == "tiny" and table.meta["world"] == world_fingerprint()
    assert table.meta["shape"] == {"envs": 48, "thetas": 24}
    assert table.d_reward().min() >= 0.0
    assert sorted(p.name for p in (out / "chunks").glob("*.npz")) == sorted(
        f"{chunk_key(table_identity(TINY, table.thetas, table.normalisers), c)}.npz"
        for c in chunks_of(table.env_ids, TINY.chunk_size))
    assert len(list((out / "chunks").glob("*.npz"))) == 3  # 48 envs in chunks of 16
    assert not list(out.glob(".*"))  # no temporary files left behind


def test_save_load_round_trip_is_bit_exact_and_memory_mapped(built, tmp_path):
    out, _ = built
    mem = TrajectoryTable.load(out, mmap=False)
    assert not isinstance(mem.features, np.memmap)
    h = mem.save(tmp_path / "again")
    back = TrajectoryTable.load(tmp_path / "again")  # mmap by default
    for name in ARRAYS:
        a, b = getattr(mem, name), getattr(back, name)
        assert isinstance(b, np.memmap), name
        assert a.dtype == b.dtype and a.shape == b.shape, name
        assert np.array_equal(a, b), name
    np.testing.assert_array_equal(back.normalisers, mem.normalisers)
    assert h == back.meta["content_hash"] == mem.meta["content_hash"]
    assert file_bytes(out) == file_bytes(tmp_path / "again")


def test_content_hash_is_stable_and_covers_arrays_and_identity(built):
    out, table = built
    h = table.meta["content_hash"]
    assert len(h) == 64
    assert content_hash(table, table.meta) == h
    assert content_hash(TrajectoryTable.load(out, mmap=False), table.meta) == h
    mem = TrajectoryTable.load(out, mmap=False)
    mem.features = mem.features.copy()
    mem.features[3, 5, 2] = np.nextafter(mem.features[3, 5, 2], np.inf)  # one ulp
    assert content_hash(mem, table.meta) != h
    assert content_hash(table, {**table.meta, "seed": 1}) != h
    assert content_hash(table, {**table.meta, "built_at": "another time"}) == h  # not part of the identity


def test_one_altered_byte_is_refused(built, tmp_path):
    d = copy_of(built, tmp_path)
    f = d / "features.npy"
    raw = bytearray(f.read_bytes())
    raw[-3] ^= 0x01  # a byte inside the last float64 value
    f.write_bytes(bytes(raw))
    with pytest.raises(TableError, match="content hash"):
        TrajectoryTable.load(d)
    # the check can be skipped explicitly, and then the altered value is what is read
    t = TrajectoryTable.load(d, verify=False)
    assert t.features[-1, -1, -1] != built[1].features[-1, -1, -1]


def test_a_table_verified_earlier_loads_by_its_recorded_hash(built, monkeypatch):
    out, table = built
    calls = []
    monkeypatch.setattr("teaching.core.table.content_hash", lambda *a: calls.append(a) or content_hash(*a))
    same = TrajectoryTable.load(out, verify=False, expected_hash=table.meta["content_hash"])
    assert not calls  # no byte re-read
    assert same.meta["content_hash"] == table.meta["content_hash"]
    with pytest.raises(TableError, match="is not the one that was verified"):
        TrajectoryTable.load(out, verify=False, expected_hash="0" * 64)


def test_a_table_from_other_world_constants_is_refused(built, tmp_path):
    d = copy_of(built, tmp_path)
    meta = json.loads((d / "meta.json").read_text())
    meta["world"] = "0123456789abcdef"
    (d / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(TableError, match="other world constants"):
        TrajectoryTable.load(d)


def test_missing_or_incomplete_tables_are_refused(built, tmp_path):
    with pytest.raises(TableError, match="meta.json missing"):
        TrajectoryTable.load(tmp_path / "nothing-here")
    d = copy_of(built, tmp_path)
    (d / "strategy.npy").unlink()
    with pytest.raises(TableError, match="incomplete or corrupt"):
        TrajectoryTable.load(d)


def test_rebuilding_computes_no_chunk_again_and_yields_identical_bytes(built, tmp_path, monkeypatch):
    d = copy_of(built, tmp_path)
    before = file_bytes(d)
    chunk_mtimes = {p.name: p.stat().st_mtime_ns for p in (d / "chunks").glob("*.npz")}

    def no_planning(*args, **kwargs):
        raise AssertionError("a finished chunk was computed again")

    monkeypatch.setattr(DRIVING, "plan_chunk", no_planning)
    again = build_table(TINY, d)
    assert again.meta["content_hash"] == built[1].meta["content_hash"]
    assert file_bytes(d) == before
    assert {p.name: p.stat().st_mtime_ns for p in (d / "chunks").glob("*.npz")} == chunk_mtimes
    identity = table_identity(TINY, again.thetas, again.normalisers)
    for c in chunks_of(again.env_ids, TINY.chunk_size):
        key, computed = build_chunk(d, identity, c, again.thetas, again.normalisers)
        assert computed is False and (d / "chunks" / f"{key}.npz").exists()


def test_a_missing_chunk_is_computed_and_only_it(built, tmp_path, monkeypatch):
    d = copy_of(built, tmp_path)
    chunks = sorted((d / "chunks").glob("*.npz"))
    chunks[1].unlink()
    calls = []
    real = DRIVING.plan_chunk

    def counting(env_ids, *args, **kwargs):
        calls.append(np.asarray(env_ids).copy())
        return real(env_ids, *args, **kwargs)

    monkeypatch.setattr(DRIVING, "plan_chunk", counting)
    again = build_table(TINY, d)
    assert len(calls) == 1 and len(calls[0]) == TINY.chunk_size
    assert again.meta["content_hash"] == built[1].meta["content_hash"]


def test_a_chunk_that_does_not_match_its_key_is_refused(built, tmp_path):
    d = copy_of(built, tmp_path)
    path = sorted((d / "chunks").glob("*.npz"))[0]
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["env_ids"] = arrays["env_ids"] + 1
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)
    with pytest.raises(TableError, match="does not match its key"):
        build_table(TINY, d)


def test_chunk_keys_depend_on_identity_and_environments():
    thetas = sample_thetas(4, theta_star=THETA_STAR)
    norm = default_normalisers()
    ident = table_identity(TINY, thetas, norm)
    ids = np.arange(5)
    assert chunk_key(ident, ids) == chunk_key(dict(ident), ids.copy())
    assert chunk_key(ident, ids) != chunk_key(ident, ids + 1)
    other = sample_thetas(4, seed=1, theta_star=THETA_STAR)
    assert chunk_key(ident, ids) != chunk_key(table_identity(TINY, other, norm), ids)
    assert chunk_key(ident, ids) != chunk_key({**ident, "world": "other"}, ids)


def test_unwritable_output_raises_table_error(built, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    with pytest.raises(TableError, match="cannot write"):
        build_table(TINY, blocker / "table")
    with pytest.raises(TableError, match="cannot write"):
        build_table(TINY, blocker)
    with pytest.raises(TableError, match="cannot write"):
        built[1].save(blocker / "table")
    assert blocker.read_text() == "not a directory"  # left as it was


def test_every_world_constant_is_in_the_fingerprint():
    """A table is refused when built under other world constants only because the fingerprint
    it stores differs: so changing any one constant must change the fingerprint."""
    base = world_fingerprint()
    for f in fields(WORLD):
        value = getattr(WORLD, f.name)
        other = tuple(v + 1 for v in value) if isinstance(value, tuple) else value + 1
        assert world_fingerprint(replace(WORLD, **{f.name: other})) != base, f.name
    assert world_fingerprint(replace(WORLD)) == base  # and it is stable


# libm and NumPy results that differ in the last bit between the two settings (checked below)
_PROBE = """import hashlib, math, numpy as np
x = np.random.default_rng(0).uniform(-1, 1, 100000)
libm = np.array([math.sin(v) + math.exp(v) + math.tan(v) for v in x])
print(hashlib.sha256(libm.tobytes()).hexdigest(), hashlib.sha256((10.0 ** x).tobytes()).hexdigest())"""


def _probe(env) -> list[str]:
    return subprocess.run([sys.executable, "-c", _PROBE], env=env, check=True, capture_output=True,
                          text=True).stdout.split()


@pytest.mark.slow
def test_the_same_preset_gives_the_same_hash_on_another_cpu(tmp_path_factory, tiny_table):
    """Reproducible builds: the tiny preset built natively and as another CPU
    would build it (libm without FMA, NumPy without AVX-512, Numba for a generic x86-64, OpenBLAS's
    oldest kernels) is bit-identical, although those settings really do change libm's and NumPy's
    last bits here: so the content hash a researcher quotes identifies the table on any x86-64."""
    # the other CPU's table: built by tests/prebuild.py under `make test` (which compiles the other CPU's
    # kernels by building it), here otherwise, by the same command in the same place
    other_table = built_once(tmp_path_factory, OTHER_CPU_TINY_TABLE, lambda out: wait_build(
        build_tiny_as_other_cpu(out.parent, out), "the tiny table for the other CPU"))
    native, other = dict(os.environ), other_cpu_env(os.environ, other_table.parent / OTHER_CPU_NUMBA_CACHE)
    libm_native, power_native = _probe(native)
    libm_other, power_other = _probe(other)
    assert libm_native != libm_other, "GLIBC_TUNABLES no longer changes libm: the test would prove nothing"
    if NUMPY_AVX512:
        assert power_native != power_other, "NPY_DISABLE_CPU_FEATURES no longer changes np.power"
    # native: the session's tiny table (tests/conftest.py), built on this CPU
    other_hash = json.loads((other_table / "meta.json").read_text())["content_hash"]
    assert other_hash == json.loads((tiny_table / "meta.json").read_text())["content_hash"]


def test_a_fresh_build_in_worker_processes_gives_the_same_table(tmp_path, built):
    """A fresh build gives the same table, byte for byte; and `build --jobs 2`, which plans the chunks in two
    spawned processes (the paper table's fastest build on two cores), is such a build: bit-identical to the
    one-process build (the shared tiny table), and a bad count is refused."""
    out = tmp_path / "jobs2"
    done = subprocess.run([sys.executable, "-m", "teaching", "build", "--preset", "tiny", "--out", str(out),
                           "--jobs", "2"], capture_output=True, text=True, check=True)
    assert "built 1,152 trajectories" in done.stdout
    two = json.loads((out / "meta.json").read_text())["content_hash"]
    assert two == built[1].meta["content_hash"]
    assert file_bytes(out) == file_bytes(built[0])
    bad = subprocess.run([sys.executable, "-m", "teaching", "build", "--preset", "tiny", "--out",
                          str(tmp_path / "bad"), "--jobs", "0"], capture_output=True, text=True)
    assert bad.returncode == 2
    assert "error: --jobs must be at least 1, got 0" in bad.stderr


# The tiny preset's content hash under the current PLANNER_VERSION (docs/benchmarks.md).  A change meant to keep every
# planned bit (a faster kernel, a refactor) must leave it as it is; a change that moves any bit bumps
# PLANNER_VERSION (which alone changes the hash), rebuilds the documented tables and updates this pin.
TINY_CONTENT_HASH = "90ce70003c8ad7f0b9e6be402ab6afcdc2d4c5834433564aa50a9bb49e0a70b3"


def test_the_tiny_table_keeps_its_hash(tiny_table):
    """What did not change proves a refactor: the tiny table, built for real, has the pinned hash."""
    got = json.loads((tiny_table / "meta.json").read_text())["content_hash"]
    assert got == TINY_CONTENT_HASH, (
        f"the tiny table's content hash moved ({got[:16]}, pinned {TINY_CONTENT_HASH[:16]}): the planner's "
        "output changed; if that is meant, bump PLANNER_VERSION, rebuild the documented tables and update the pin")
