"""A job whose messages the broker lost (Redis restarted empty mid-job) does not stay "running"
forever: the worker's watchdog notices after its quiet time and relaunches it (finished chunks
kept), or after repeated losses fails it, with an alarm on the job page and the designer, logged at
ERROR.  What is checked are the events (the relaunch counted, every chunk stored once); the waits
only guard against a hang, far above what the steps take on a loaded machine.

The worker runs in this process (celery.contrib.testing, solo pool) so that it shares the test
database, on the real Redis with a queue of its own; "restarted empty" is deleting that queue's
keys only (other people's data on the same Redis is never touched).
"""
from __future__ import annotations

import collections
import logging
import uuid
from datetime import timedelta

import pytest
import redis
from celery.contrib.testing.worker import start_worker
from django.utils import timezone

from precompute import jobs, watchdog, work
from precompute.models import Job
from teaching.core.build import Preset
from tests.services import wait_until

pytestmark = [pytest.mark.slow, pytest.mark.redis]

# 8 chunks of ~0.3-1 s each on one core: the purge lands with most of the job still queued.
LOST = Preset("test-lost", n_envs=64, n_thetas=48, chunk_size=8, seed=7)


def purge(url: str, queue: str) -> int:
    """Everything Redis holds for `queue` (its list and kombu's priority lists), as if restarted empty."""
    client = redis.Redis.from_url(url)
    keys = [queue] + [f"{queue}\x06\x16{p}" for p in range(10)]
    try:
        return client.delete(*keys)
    finally:
        client.close()


@pytest.fixture
def redis_worker(transactional_db, redis_url, celery_app_with, settings):
    # after the database (so stopped before it): a task still running at the end writes to a live
    # database, not one pytest-django has already closed ("Database access not allowed")
    queue = f"precompute-test-{uuid.uuid4().hex[:8]}"
    app = celery_app_with(broker_url=redis_url, result_backend=redis_url, task_always_eager=False,
                          broker_transport_options={"visibility_timeout": 3600})
    # a check every half second: the watchdog acts soon after a job's quiet time is over (a round that
    # finds no quiet job is one small query)
    settings.PRECOMPUTE_WATCHDOG_QUIET, settings.PRECOMPUTE_WATCHDOG_EVERY = 10, 0.5
    with start_worker(app, pool="solo", perform_ping_check=False, loglevel="WARNING", shutdown_timeout=60,
                      queues=[queue]) as worker:
        thread = watchdog.start(app)  # what worker_ready starts in a real worker
        try:
            yield worker, queue
        finally:
            watchdog.stop()
            thread.join(10)
    purge(redis_url, queue)


def test_a_job_whose_messages_the_broker_lost_is_relaunched(redis_worker, redis_url, tmp_path, staff_client,
                                                            caplog):
    _, queue = redis_worker
    out = tmp_path / "table"
    job = jobs.create_table_job(LOST, out, queue=queue)
    wait_until(lambda: Job.objects.get(pk=job.pk).chunks_done >= 2, 900, "the worker storing its first chunks")
    purge(redis_url, queue)  # Redis "restarted empty": the queued chunks are gone
    stored_before = {e["key"] for e in work.read_journal(out) if e["event"] == "stored"}
    assert len(stored_before) < job.chunks_total

    with caplog.at_level(logging.ERROR, logger="precompute.watchdog"):
        job = jobs.wait(job, progress=False, timeout=900)  # a hang guard: quiet time 10 s, then 8 small chunks
    assert job.status == Job.SUCCEEDED, job.error
    assert job.watchdog_relaunches == 1 and job.attempts == 2
    print(f"lost at {len(stored_before)}/{job.chunks_total} chunks; relaunched and finished")
    assert "the broker lost its tasks" in job.alarm and "Relaunched automatically (1 of at most 2)" in job.alarm
    assert any(r.levelno == logging.ERROR and "the broker lost its tasks" in r.getMessage() for r in caplog.records)
    stored = collections.Counter(e["key"] for e in work.read_journal(out) if e["event"] == "stored")
    assert len(stored) == job.chunks_total and set(stored.values()) == {1}  # nothing computed twice
    assert "the broker lost its tasks" in staff_client.get(job.get_absolute_url()).content.decode()


def test_a_job_lost_again_and_again_fails_with_the_alarm(redis_worker, tmp_path, staff_client, settings, caplog):
    """Lost after MAX_RELAUNCHES automatic relaunches: failed, with the alarm on the job page and the
    designer.  (A job whose canvas was never sent stands for one whose messages were lost.)"""
    _, queue = redis_worker
    settings.TABLES_DIR = tmp_path
    job = jobs.create_table_job(LOST, tmp_path / "t", queue=queue, start=False)
    Job.objects.filter(pk=job.pk).update(status=Job.RUNNING, watchdog_relaunches=watchdog.MAX_RELAUNCHES,
                                         started_at=timezone.now() - timedelta(seconds=30))
    with caplog.at_level(logging.ERROR, logger="precompute.watchdog"):
        job = jobs.wait(job, progress=False, timeout=600)  # a hang guard: the quiet time is 10 s
    assert job.status == Job.FAILED
    assert job.error == "watchdog: RuntimeError: the broker lost this job's tasks"
    assert "marked failed" in job.alarm and any(r.levelno == logging.ERROR for r in caplog.records)
    for page in (job.get_absolute_url(), "/precompute/design/"):
        assert "the broker lost its tasks" in staff_client.get(page).content.decode(), page


def test_a_job_whose_task_just_started_is_not_quiet(db):
    """Slow is not lost: every task start is a heartbeat, so a job whose chunk takes long is not
    a candidate until it has been silent for the whole quiet time."""
    job = Job.objects.create(kind=Job.TABLE, status=Job.RUNNING, params={"preset": {}, "out": "/x"},
                             started_at=timezone.now() - timedelta(minutes=10))
    assert [j.pk for j, _ in watchdog.quiet_jobs(timedelta(seconds=60))] == [job.pk]
    Job.objects.filter(pk=job.pk).update(heartbeat_at=timezone.now())  # a task of it just started
    assert watchdog.quiet_jobs(timedelta(seconds=60)) == []
