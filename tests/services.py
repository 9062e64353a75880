"""The services some tests need on this machine (PostgreSQL, Redis), checked one way everywhere.

Whether a missing service skips or fails the test is the ``require_service`` fixture's business
(tests/conftest.py): under CI it fails.
"""
from __future__ import annotations

import os

PG_URL = os.environ.get("POSTGRES_TEST_URL", "postgres://postgres@127.0.0.1:5432/test")


def postgres_reachable(url: str = PG_URL) -> bool:
    import psycopg

    try:
        psycopg.connect(url.replace("postgres://", "postgresql://", 1), connect_timeout=5).close()
        return True
    except psycopg.OperationalError:
        return False


def redis_reachable(url: str) -> bool:
    import redis

    try:
        return bool(redis.Redis.from_url(url, socket_connect_timeout=2).ping())
    except redis.exceptions.ConnectionError:
        return False
