"""A job whose messages the broker lost (Redis restarted empty mid-job) does not stay "running"
forever (issue 22, item 6): the worker's watchdog notices within 2 minutes and relaunches it
(finished chunks kept), or after repeated losses fails it, with an alarm on the job page and the
designer, logged at ERROR.

The worker runs in this process (celery.contrib.testing, solo pool) so that it shares the test
database, on the real Redis with a queue of its own; "restarted empty" is deleting that queue's
keys only (other people's data on the same Redis is never touched).
"""
from __future__ import annotations

import collections
import logging
import time
import uuid
from datetime import timedelta

import pytest
import redis
from celery.contrib.testing.worker import start_worker
from django.utils import timezone

from precompute import jobs, watchdog, work
from precompute.models import Job
from teaching.core.build import Preset

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
def redis_worker(redis_url, celery_app_with, settings):
    queue = f"precompute-test-{uuid.uuid4().hex[:8]}"
    app = celery_app_with(broker_url=redis_url, result_backend=redis_url, task_always_eager=False,
                          broker_transport_options={"visibility_timeout": 3600})
    settings.PRECOMPUTE_WATCHDOG_QUIET, settings.PRECOMPUTE_WATCHDOG_EVERY = 10, 2
    with start_worker(app, pool="solo", perform_ping_check=False, loglevel="WARNING", shutdown_timeout=60,
                      queues=[queue]) as worker:
        thread = watchdog.start(app)  # what worker_ready starts in a real worker
        try:
            yield worker, queue
        finally:
            watchdog.stop()
            thread.join(10)
    purge(redis_url, queue)


def test_a_job_whose_messages_the_broker_lost_is_relaunched_within_two_minutes(
        redis_worker, redis_url, transactional_db, tmp_path, staff_client, caplog):
    _, queue = redis_worker
    out = tmp_path / "table"
    job = jobs.create_table_job(LOST, out, queue=queue)
    deadline = time.monotonic() + 120
    while Job.objects.get(pk=job.pk).chunks_done < 2:
        assert time.monotonic() < deadline, "the worker never got going"
        time.sleep(0.05)
    purge(redis_url, queue)  # Redis "restarted empty": the queued chunks are gone
    lost_at = time.monotonic()
    stored_before = {e["key"] for e in work.read_journal(out) if e["event"] == "stored"}
    assert len(stored_before) < job.chunks_total

    with caplog.at_level(logging.ERROR, logger="precompute.watchdog"):
        job = jobs.wait(job, progress=False, timeout=120)
    took = time.monotonic() - lost_at
    assert job.status == Job.SUCCEEDED, job.error
    assert took < 120 and job.watchdog_relaunches == 1 and job.attempts == 2
    print(f"lost at {len(stored_before)}/{job.chunks_total} chunks; relaunched and finished {took:.1f} s later")
    assert "the broker lost its tasks" in job.alarm and "Relaunched automatically (1 of at most 2)" in job.alarm
    assert any(r.levelno == logging.ERROR and "the broker lost its tasks" in r.getMessage() for r in caplog.records)
    stored = collections.Counter(e["key"] for e in work.read_journal(out) if e["event"] == "stored")
    assert len(stored) == job.chunks_total and set(stored.values()) == {1}  # nothing computed twice
    assert "the broker lost its tasks" in staff_client.get(job.get_absolute_url()).content.decode()


def test_a_job_lost_again_and_again_fails_with_the_alarm(redis_worker, transactional_db, tmp_path, staff_client,
                                                         settings, caplog):
    """Lost after MAX_RELAUNCHES automatic relaunches: failed, with the alarm on the job page and the
    designer.  (A job whose canvas was never sent stands for one whose messages were lost.)"""
    _, queue = redis_worker
    settings.TABLES_DIR = tmp_path
    job = jobs.create_table_job(LOST, tmp_path / "t", queue=queue, start=False)
    Job.objects.filter(pk=job.pk).update(status=Job.RUNNING, watchdog_relaunches=watchdog.MAX_RELAUNCHES,
                                         started_at=timezone.now() - timedelta(seconds=30))
    t0 = time.monotonic()
    with caplog.at_level(logging.ERROR, logger="precompute.watchdog"):
        job = jobs.wait(job, progress=False, timeout=60)
    assert job.status == Job.FAILED and time.monotonic() - t0 < 60
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
