"""The services some tests need on this machine (PostgreSQL, Redis), checked one way everywhere.

Whether a missing service skips or fails the test is :func:`require_service`'s business (the
fixture of that name in tests/conftest.py calls it): under CI it fails.
"""
from __future__ import annotations

import os
import socket
import threading
import time
from contextlib import contextmanager

import psycopg
import pytest
import redis

PG_URL = os.environ.get("POSTGRES_TEST_URL", "postgres://postgres@127.0.0.1:5432/test")


class Hung(AssertionError):
    """A step that a test waits for never happened: raised by :func:`wait_until`'s hang guard."""


def wait_until(predicate, timeout: float, what: str, poll: float = 0.05, detail=lambda: ""):
    """predicate()'s first true value, polled every `poll` s; :class:`Hung` naming `what` (and
    detail()'s text, a log tail say) if none came within `timeout` s.

    The timeout only tells a hang from progress, so it sits at least ten times above what the step
    takes on a loaded machine; how long the step took is never asserted (a shared 2-core machine
    can stretch anything), it is a benchmark's business (bench/)."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise Hung(f"{what}: not within {timeout:.0f} s (a hang?)\n{detail()}")
        time.sleep(poll)


def require_service(ok: bool, what: str, ci: bool) -> None:
    """A test (or fixture, of any scope) whose service is missing fails under CI and is skipped
    elsewhere, with `what` as the reason."""
    if not ok:
        if ci:
            pytest.fail(f"CI is set but {what}")
        pytest.skip(f"{what} (allowed only outside CI)")


def postgres_reachable(url: str = PG_URL) -> bool:
    try:
        psycopg.connect(url.replace("postgres://", "postgresql://", 1), connect_timeout=5).close()
        return True
    except psycopg.OperationalError:
        return False


def redis_reachable(url: str) -> bool:
    try:
        return bool(redis.Redis.from_url(url, socket_connect_timeout=2).ping())
    except redis.exceptions.ConnectionError:
        return False


@contextmanager
def blackhole():
    """A hung service on a free loopback port: it accepts connections and never answers (a Redis
    stuck in a long command, a half-dead proxy).  Yields the port."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(128)
    server.settimeout(0.2)
    held, stop = [], threading.Event()

    def accept():
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except TimeoutError:
                continue
            except OSError:
                return

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield server.getsockname()[1]
    finally:
        stop.set()
        thread.join(2)
        for conn in held:
            conn.close()
        server.close()
