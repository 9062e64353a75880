"""Jobs whose tasks the broker lost: noticed within a couple of minutes, relaunched, or failed
with an alarm.

A Redis restarted empty (no persistence, or a failover) forgets every queued message, and a
chord whose members are gone never calls back: the job would stay "running" at 3/38 forever.
recovery.py cannot help (it puts back messages a dead worker held; these no longer exist).

So every worker runs a watchdog thread (started when the worker is ready; scripts/serve.sh and
scripts/demo.sh run no Celery beat).  Every PRECOMPUTE_WATCHDOG_EVERY seconds it looks for
pending or running jobs with no sign of life for PRECOMPUTE_WATCHDOG_QUIET seconds: no task of
theirs started (``Job.heartbeat_at``, set by every task) and no unit finished.  For those it asks
the live workers (Celery ``inspect``) what they hold.  A job is *lost* when no worker runs, has
reserved or has scheduled a task of it while some worker serving its queue has a free process:
a message still in the queue would have been taken by that worker long before.  (No worker
answering, or every worker of the queue busy, proves nothing: the job is left alone, and its
page says it is stalled after 5 minutes.)

A lost job is relaunched (jobs.launch: stored chunks and frozen conditions are skipped, so only
the missing work is computed), at most MAX_RELAUNCHES times in a row; lost again after that, it
is marked failed.  Either way the job's ``alarm`` says what happened (job page, job list and
designer show it) and it is logged at ERROR.  Two workers' watchdogs never act on the same job
twice: each claims it by moving its ``started_at`` first.
"""
from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from datetime import timedelta

from celery.signals import worker_ready, worker_shutdown
from django.conf import settings
from django.db import close_old_connections
from django.db.models import F, Max
from django.utils import timezone

from .models import Job
from .specs import SpecFormatError
from .tasks import default_queue, fail_job

log = logging.getLogger(__name__)

MAX_RELAUNCHES = 2
INSPECT_TIMEOUT = 1.0  # seconds live workers have to say what they hold


def quiet_seconds() -> float:
    return float(getattr(settings, "PRECOMPUTE_WATCHDOG_QUIET", 60))


def every_seconds() -> float:
    return float(getattr(settings, "PRECOMPUTE_WATCHDOG_EVERY", 15))


@dataclass
class Survey:
    """What the live workers hold: job ids of their tasks, and the queues with a free process."""
    replied: bool = False
    held: set = field(default_factory=set)
    idle_queues: set = field(default_factory=set)


def survey(app, timeout: float = INSPECT_TIMEOUT) -> Survey:
    inspect = app.control.inspect(timeout=timeout)
    active = inspect.active() or {}
    queues = inspect.active_queues() or {}
    stats = inspect.stats() or {}
    out = Survey(replied=bool(queues))
    for reply in (active, inspect.reserved() or {}, inspect.scheduled() or {}):
        for tasks in reply.values():
            for task in tasks:
                request = task.get("request", task)  # scheduled() wraps the request
                job_id = (request.get("kwargs") or {}).get("job_id")
                if job_id is None and str(request.get("name", "")).startswith("precompute.") and request.get("args"):
                    job_id = request["args"][0]  # a message sent by position by older code
                if isinstance(job_id, int):
                    out.held.add(job_id)
    for worker, served in queues.items():
        processes = ((stats.get(worker) or {}).get("pool") or {}).get("max-concurrency") or 1
        if len(active.get(worker, [])) < processes:
            out.idle_queues |= {q["name"] for q in served}
    return out


def quiet_jobs(quiet: timedelta, now=None) -> list[tuple[Job, timedelta]]:
    """Pending or running jobs with no task started and no unit finished for `quiet`."""
    now = now or timezone.now()
    found = []
    for job in Job.objects.filter(status__in=(Job.PENDING, Job.RUNNING), started_at__lte=now - quiet):
        last_part = job.parts.filter(finished_at__gte=job.started_at).aggregate(m=Max("finished_at"))["m"]
        latest = max(t for t in (job.started_at, job.heartbeat_at, last_part) if t is not None)
        if now - latest >= quiet:
            found.append((job, now - latest))
    return found


def check(app) -> list[Job]:
    """One round: the lost jobs, each relaunched or failed (returned)."""
    quiet = quiet_jobs(timedelta(seconds=quiet_seconds()))
    if not quiet:
        return []
    workers = survey(app)
    if not workers.replied:
        return []
    acted = []
    for job, silent in quiet:
        queue = job.params.get("queue") or default_queue()
        if job.pk not in workers.held and queue in workers.idle_queues and handle_lost(job, silent, queue):
            acted.append(job)
    return acted


def handle_lost(job: Job, silent: timedelta, queue: str) -> bool:
    """Relaunch a job whose tasks are gone, or fail it after MAX_RELAUNCHES; False if another
    watchdog (or a person) got to it first."""
    claimed = Job.objects.filter(pk=job.pk, started_at=job.started_at,
                                 status__in=(Job.PENDING, Job.RUNNING)).update(started_at=timezone.now())
    if not claimed:
        return False
    job.refresh_from_db()
    unit = "chunk" if job.kind == Job.TABLE else "part"
    seen = (f"{timezone.localtime():%Y-%m-%d %H:%M:%S}: no task of this job ran for {silent.total_seconds():.0f} s "
            f"and no worker holds one, while a worker of queue {queue!r} is idle: the broker lost its tasks "
            f"(restarted empty?) at {job.chunks_done}/{job.chunks_total} {unit}s.")
    if job.watchdog_relaunches >= MAX_RELAUNCHES:
        alarm = (f"{seen} Lost again after {MAX_RELAUNCHES} automatic relaunches: marked failed. Check the broker "
                 "and the workers, then press Retry (finished work is kept).")
        Job.objects.filter(pk=job.pk).update(alarm=alarm)
        fail_job(job.pk, RuntimeError("the broker lost this job's tasks"), where="watchdog: ")
        log.error("precompute: job %s (%s): %s", job.pk, job.label, alarm)
        return True
    n = job.watchdog_relaunches + 1
    alarm = f"{seen} Relaunched automatically ({n} of at most {MAX_RELAUNCHES}); finished {unit}s are kept."
    Job.objects.filter(pk=job.pk).update(alarm=alarm, watchdog_relaunches=F("watchdog_relaunches") + 1)
    log.error("precompute: job %s (%s): %s", job.pk, job.label, alarm)
    job.refresh_from_db()
    from . import jobs  # noqa: PLC0415  (the launcher brings in the teaching core: here, not at worker boot)
    try:
        jobs.launch(job, by_watchdog=True)
    except (jobs.BrokerUnavailable, SpecFormatError):
        pass  # launch marked the job failed with the reason; its alarm says what came before
    return True


def watch(app, stop: threading.Event) -> None:
    """The watchdog loop: one check every PRECOMPUTE_WATCHDOG_EVERY seconds until `stop`."""
    last_error = None
    while not stop.wait(every_seconds()):
        try:
            check(app)
            last_error = None
        except Exception as exc:  # never take the worker down over this; try again next round
            if repr(exc) != last_error:  # once per kind of trouble, not every round
                log.exception("precompute: the job watchdog's check failed")
            last_error = repr(exc)
        finally:
            close_old_connections()


_stop = threading.Event()


def start(app) -> threading.Thread:
    _stop.clear()
    thread = threading.Thread(target=watch, args=(app, _stop), name="job-watchdog", daemon=True)
    thread.start()
    return thread


def stop() -> None:
    _stop.set()


@worker_ready.connect
def _on_worker_ready(sender=None, **_):
    app = getattr(sender, "app", None)
    if app is not None and every_seconds() > 0:
        start(app)


@worker_shutdown.connect
def _on_worker_shutdown(**_):
    stop()
