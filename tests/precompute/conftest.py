"""Fixtures for the precompute tests: a small preset, its one-process reference build,
and an in-process Celery worker (celery.contrib.testing) on the memory transport."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from celery.contrib.testing.worker import start_worker
from kombu.transport import TRANSPORT_ALIASES, memory

from config.celery import app
from teaching.core.build import Preset, build_table
from teaching.core.table import ARRAYS, TrajectoryTable
from tests.services import redis_reachable

# 16 environments × 16 thetas in 4 chunks of 4: big enough for the chord and the fault
# test to have work in flight, small enough for ~1 s per chunk on one core.
SMALL = Preset("test-small", n_envs=16, n_thetas=16, chunk_size=4, seed=3)


@pytest.fixture(scope="session")
def reference(tmp_path_factory) -> Path:
    """The one-process build of SMALL (teaching.core.build.build_table, Numba's default thread count)."""
    out = tmp_path_factory.mktemp("reference")
    build_table(SMALL, out)
    return out


def _assert_same_table(a, b):
    """Bit-for-bit: every array file, and the content hash."""
    ta, tb = TrajectoryTable.load(a), TrajectoryTable.load(b)
    assert ta.meta["content_hash"] == tb.meta["content_hash"]
    for name in ARRAYS:
        assert (Path(a) / f"{name}.npy").read_bytes() == (Path(b) / f"{name}.npy").read_bytes(), name
        assert np.array_equal(getattr(ta, name), getattr(tb, name))


@pytest.fixture
def assert_same_table():
    return _assert_same_table


@pytest.fixture
def small_preset():
    return SMALL


class QuickMemoryTransport(memory.Transport):
    """kombu's memory transport, answering within 10 ms.  Its worker loop (celery.worker.loops.synloop) waits
    2 s for a message before it looks at its stop flag, once more after seeing it, and the virtual transport
    polls once a second: 1-4 s of nothing per task hop and per test.  The broker's state is memory's own."""

    polling_interval = 0.01

    def drain_events(self, connection, timeout=None):
        return super().drain_events(connection, timeout=None if timeout is None else min(timeout, 0.05))


# kombu calls an alias that is callable and takes what it returns: the class itself.  A "conftest:Class" path
# is looked up when a worker starts, and by then sys.modules["conftest"] may be another directory's conftest.
TRANSPORT_ALIASES["quickmemory"] = lambda: QuickMemoryTransport


def _forget_connections(app):
    """Connections, producers and this thread's result backend made under the old settings
    must not be reused."""
    app._pool = None
    app.amqp._producer_pool = None
    try:
        del app._local.backend
    except AttributeError:
        pass


@pytest.fixture
def celery_app_with():
    """Switch the project's Celery app to other settings for one test, and back."""
    saved = {}

    def switch(**conf):
        for k in conf:
            saved.setdefault(k, app.conf.get(k))
        app.conf.update(conf)
        _forget_connections(app)
        return app

    try:
        yield switch
    finally:
        app.conf.update(saved)
        _forget_connections(app)


@pytest.fixture
def celery_app_inprocess(celery_app_with):
    """The project's Celery app switched to the (quick) memory transport and result store."""
    return celery_app_with(broker_url="quickmemory://", result_backend="cache+memory://", broker_transport_options={},
                           task_always_eager=False)


@pytest.fixture
def inprocess_worker(celery_app_inprocess):
    with start_worker(celery_app_inprocess, pool="solo", perform_ping_check=False, loglevel="WARNING",
                      shutdown_timeout=60) as worker:
        yield worker


@pytest.fixture
def redis_url(require_service):
    """Redis for the real-worker tests (database 13 unless $PRECOMPUTE_TEST_REDIS says otherwise).
    Under CI=true an unreachable Redis fails the test; elsewhere it skips."""
    url = os.environ.get("PRECOMPUTE_TEST_REDIS", "redis://127.0.0.1:6379/13")
    require_service(redis_reachable(url), f"no Redis at {url}")
    return url
