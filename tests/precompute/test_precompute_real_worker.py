"""Real `celery worker` processes against the Redis on 127.0.0.1:6379 (and one on the
embedded filesystem broker).

The worker is a separate process with its own settings from the environment
(Redis broker and result backend, a scratch SQLite it never writes to), so
these canvases run with job_id=None: the state lives in the chunk files and
build.log, which is what the assertions read.  Each test uses its own queue.
Under CI=true a missing Redis fails instead of skipping (conftest.redis_url).
"""
from __future__ import annotations

import collections
import os
import re
import signal
import time
import uuid

import pytest
from celery import Celery

from precompute import jobs, procs, work
from teaching.core.build import Preset, build_table
from tests.services import wait_until

pytestmark = pytest.mark.slow

# ~1.5 s per chunk on one core: long enough to be killed in the middle of one.
FAULT = Preset("test-fault", n_envs=64, n_thetas=128, chunk_size=16, seed=5)
# The production default: a dead worker's message must come back long before this
# (precompute/recovery.py, when the next worker starts), never by waiting it out.
VISIBILITY_TIMEOUT = 3600


def client_app(url: str) -> Celery:
    app = Celery("precompute-test-client", broker=url, backend=url)
    app.conf.update(broker_transport_options={"visibility_timeout": VISIBILITY_TIMEOUT}, result_expires=600)
    return app


def worker_env(url: str, tmp_path) -> dict:
    return {"CELERY_BROKER_URL": url, "CELERY_RESULT_BACKEND": url, "VAR_DIR": str(tmp_path / "worker-var"),
            "DATABASE_URL": f"sqlite:///{tmp_path / 'worker.sqlite3'}", "PRECOMPUTE_THREADS": "1",
            "CELERY_VISIBILITY_TIMEOUT": str(VISIBILITY_TIMEOUT), "PYTHONUNBUFFERED": "1",
            "CELERY_SKIP_CHECKS": "1"}  # as config/supervisord.conf runs it


def maps_mention(pid: int, *names: str) -> bool:
    """Whether a shared object whose path contains one of `names` is mapped into process `pid`."""
    with open(f"/proc/{pid}/maps") as maps:
        return any(name in line for line in maps for name in names)


def numba_pool_loaded(pid: int) -> bool:
    return maps_mention(pid, "omppool", "tbbpool", "workqueue")


def log_tail(proc) -> str:
    return proc.log_path.read_text()[-4000:] if proc.log_path and proc.log_path.exists() else ""


@pytest.mark.redis
def test_real_worker_builds_the_same_table(redis_url, small_preset, reference, tmp_path, assert_same_table):
    queue = f"precompute-test-{uuid.uuid4().hex[:8]}"
    app = client_app(redis_url)
    worker = procs.start_worker(queue, concurrency=1, env=worker_env(redis_url, tmp_path),
                                log_path=tmp_path / "worker.log")
    try:
        procs.wait_ready(worker, timeout=90)
        out = tmp_path / "table"
        spec = work.table_spec(small_preset, out)
        result = jobs.table_canvas(None, spec, queue=queue, app=app).apply_async()
        try:
            info = result.get(timeout=150, propagate=True)
        except Exception as exc:
            pytest.fail(f"{type(exc).__name__}: {exc}\nworker log:\n{log_tail(worker)}")
        assert info["n_envs"] == small_preset.n_envs and info["min_d_reward"] >= 0
        assert_same_table(out, reference)
        hosts = {e["host"] for e in work.read_journal(out) if e["event"] == "stored"}
        pids = {int(h.rsplit(":", 1)[1]) for h in hosts}
        assert os.getpid() not in pids  # computed in the worker
        # Fork safety: the prefork main process never started Numba's threading layer
        # (OpenMP / TBB / workqueue library not even loaded); the pool child that planned did.
        assert not numba_pool_loaded(worker.pid)
        planners = pids & set(procs.pool_children(worker.pid))
        assert planners and all(numba_pool_loaded(pid) for pid in planners)
        # A quick boot: the main process never loads the numeric stack (precompute/steps.py); its pool
        # child loaded it for the first task.
        assert not maps_mention(worker.pid, "llvmlite", "/scipy/")
        assert all(maps_mention(pid, "llvmlite") for pid in planners)
    finally:
        procs.stop_worker(worker)
        app.close()


@pytest.mark.redis
def test_killed_worker_is_replaced_and_nothing_stored_is_recomputed(redis_url, tmp_path, assert_same_table):
    reference = tmp_path / "reference"  # built below, while worker 2 starts and finishes the job
    queue = f"precompute-test-{uuid.uuid4().hex[:8]}"
    app = client_app(redis_url)
    env = worker_env(redis_url, tmp_path)
    out = tmp_path / "table"
    spec = work.table_spec(FAULT, out)
    first = procs.start_worker(queue, concurrency=1, env=env, log_path=tmp_path / "worker1.log", hostname="w1@%h")
    second = None
    try:
        procs.wait_ready(first, timeout=90)
        result = jobs.table_canvas(None, spec, queue=queue, app=app).apply_async()
        # Wait until worker 1 has stored a chunk and is in the middle of the next one.
        def mid_chunk():
            events = work.read_journal(out)
            stored = {e["key"] for e in events if e["event"] == "stored"}
            running = [e for e in events if e["event"] == "start" and e["key"] not in stored]
            return running[-1] if stored and running else None

        victim = wait_until(mid_chunk, 900, "worker 1 storing a chunk and starting the next", poll=0.01,
                            detail=lambda: log_tail(first))
        child = int(victim["host"].rsplit(":", 1)[1])
        kids = procs.pool_children(first.pid)
        assert child != first.pid and (not kids or child in kids)
        os.kill(first.pid, signal.SIGKILL)  # the machine dies: main process and pool child
        os.kill(child, signal.SIGKILL)
        first.wait(10)
        killed_at = time.time()
        stored_before = {e["key"] for e in work.read_journal(out) if e["event"] == "stored"}
        assert victim["key"] not in stored_before and not work.chunk_path(out, victim["key"]).exists()

        # Worker 2 starts at once: it finds worker 1's unacknowledged message, held by no live
        # worker, and puts it back (precompute/recovery.py) instead of waiting an hour for it.
        second = procs.start_worker(queue, concurrency=1, env=env, log_path=tmp_path / "worker2.log",
                                    hostname="w2@%h")
        # The one-process build to compare with, made here rather than first: it only has to exist by the
        # comparison, and meanwhile this process would otherwise just wait for worker 2.
        build_table(FAULT, reference)
        try:
            info = result.get(timeout=150, propagate=True)
        except Exception as exc:
            pytest.fail(f"{type(exc).__name__}: {exc}\nworker 2 log:\n{log_tail(second)}")
        # the interrupted chunk's message, and on a busy machine sometimes the next one worker 1 had
        # already reserved: every unacknowledged message goes back, however many
        put_back = re.search(r"put back (\d+) task\(s\) left by a worker that died", log_tail(second))
        assert put_back and int(put_back.group(1)) >= 1, log_tail(second)
        assert info["content_hash"] == work.load_table(reference).meta["content_hash"]
        assert_same_table(out, reference)

        events = work.read_journal(out)
        stored = collections.Counter(e["key"] for e in events if e["event"] == "stored")
        assert len(stored) == spec["n_chunks"] and set(stored.values()) == {1}, stored
        after = [e for e in events if e["time"] >= killed_at]
        # nothing that was stored before the kill was started again
        assert not [e for e in after if e["event"] == "start" and e["key"] in stored_before]
        # the interrupted chunk was finished by worker 2
        redone = [e for e in after if e["event"] == "stored" and e["key"] == victim["key"]]
        assert len(redone) == 1 and redone[0]["host"] != victim["host"]
        assert any(e["event"] == "published" for e in after)
    finally:
        procs.stop_worker(first, grace=5)
        if second is not None:
            procs.stop_worker(second)
        app.close()


def test_real_worker_on_the_embedded_filesystem_broker(small_preset, reference, tmp_path, assert_same_table):
    """The embedded default needs no server: kombu's filesystem transport under VAR_DIR/broker.
    (Results go to Celery's file backend here because the worker cannot reach the test database.)"""
    var = tmp_path / "var"
    broker = var / "broker"
    results = tmp_path / "results"
    results.mkdir()
    queue = f"precompute-test-{uuid.uuid4().hex[:8]}"
    app = Celery("precompute-test-fs", broker="filesystem://", backend=f"file://{results}")
    app.conf.broker_transport_options = {"data_folder_in": str(broker / "out"), "data_folder_out": str(broker / "out"),
                                         "processed_folder": str(broker / "processed"),
                                         "control_folder": str(broker / "control")}
    for sub in ("out", "processed", "control"):
        (broker / sub).mkdir(parents=True, exist_ok=True)
    env = {"VAR_DIR": str(var), "CELERY_BROKER_URL": "filesystem://", "CELERY_RESULT_BACKEND": f"file://{results}",
           "DATABASE_URL": f"sqlite:///{tmp_path / 'worker.sqlite3'}", "PRECOMPUTE_THREADS": "1"}
    worker = procs.start_worker(queue, concurrency=2, env=env, log_path=tmp_path / "worker.log")
    try:
        procs.wait_ready(worker, timeout=90)
        out = tmp_path / "table"
        result = jobs.table_canvas(None, work.table_spec(small_preset, out), queue=queue, app=app).apply_async()
        try:
            result.get(timeout=150, propagate=True, interval=0.2)
        except Exception as exc:
            pytest.fail(f"{type(exc).__name__}: {exc}\nworker log:\n{log_tail(worker)}")
        assert_same_table(out, reference)
        assert len({e["host"] for e in work.read_journal(out) if e["event"] == "stored"}) >= 1
    finally:
        procs.stop_worker(worker)
        app.close()
