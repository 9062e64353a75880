"""The production server that the behaviour tests of tests/load share (test_supervision.py,
test_slow_bodies.py, test_slow_clients.py).

Starting one (a fresh database, migrate, the demo study, nginx, gunicorn's workers warmed, a Celery
worker) and stopping it costs about a minute of a loaded machine, and what each of those tests
checks does not depend on the server being new: each reads only what the server logged after it
began (harness.Server.mark), and what one test does to the server (a process killed, gunicorn
stopped) it waits to see undone before it ends.  The load test (test_load.py) keeps a server of its
own: it needs production's worker count and restarts PostgreSQL under it.
"""
from __future__ import annotations

import pytest

from tests.load import harness
from tests.services import PG_URL, postgres_reachable, redis_reachable, require_service


@pytest.fixture(scope="session")
def few_workers_server(tmp_path_factory, demo_table, ci):
    """scripts/serve.sh with harness.FEW_WORKERS gunicorn workers on the demo study, once per run."""
    require_service(postgres_reachable(), f"PostgreSQL at {PG_URL} is unreachable", ci)
    require_service(redis_reachable(harness.REDIS_URL), f"Redis at {harness.REDIS_URL} is unreachable", ci)
    with harness.Server(tmp_path_factory.mktemp("few-workers"), workers=harness.FEW_WORKERS,
                        demo_table=demo_table) as server:
        yield server


@pytest.fixture
def shared_server(few_workers_server):
    """The shared server, serving when the test begins and when it ends (a test that stopped or killed
    one of its programs has waited for it to come back; checked here, so the next test is not the one
    to fail)."""
    assert harness.visit(few_workers_server.base_url + "/", 10).answered
    yield few_workers_server
    assert harness.visit(few_workers_server.base_url + "/", 10).answered, few_workers_server.log_tail()
