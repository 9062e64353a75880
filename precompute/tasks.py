"""Celery tasks: table chunks and publishing, study conditions and the test set.

Every task is ``acks_late`` with ``reject_on_worker_lost``: the broker keeps a
message until the task has finished, so a worker that dies mid-chunk leaves
its message to be delivered again (Redis: as soon as the next worker starts,
precompute/recovery.py, else after the visibility timeout; a killed pool
child: at once), and the content-addressed chunk files make the second
delivery either skip (stored) or redo (not stored) the chunk.

Worker pool: **prefork** (Celery's default).  The planner's Numba kernels run
on a threading layer (OpenMP or workqueue) that is not fork-safe once used,
but the prefork parent never even imports them (the work lives in
precompute/steps.py, which a pool child imports at its first task: a quick
boot), and each child starts its own thread pool after the fork.  Each child uses
``PRECOMPUTE_THREADS`` Numba threads (default: cores // concurrency, so ``-c 2``
on 2 cores gives 1 thread per child and ``-c 1`` gives 2); the ``threads`` pool is not safe with Numba's
workqueue layer and is not supported.  See docs/scaling.md.

``job_id`` may be None: the task then touches no database (used by the
benchmark and by the real-worker tests, whose worker process has no access
to the test database); the chunk files and build.log carry the state.
"""
from __future__ import annotations

import importlib
import inspect
import logging
import os
import time
import traceback

from celery import Task, shared_task
from celery.signals import worker_init
from django.conf import settings
from django.db import transaction
from django.db.models import F
from django.utils import timezone

from studyapp.models import Condition, Study

from .models import Job, Part
from .procs import host_id
from .specs import BuildRefused, StudyJobSpec

log = logging.getLogger(__name__)


def default_queue() -> str:
    """The queue a job's tasks go to unless the job names one (settings.PRECOMPUTE_QUEUE)."""
    return getattr(settings, "PRECOMPUTE_QUEUE", None) or "celery"


def numba_threads() -> int:
    return max(1, int(os.environ.get("PRECOMPUTE_THREADS", "1")))


@worker_init.connect
def _share_cores(sender=None, **_):
    """In a prefork worker's main process, before the pool forks: unless PRECOMPUTE_THREADS is
    set, give each of the -c children cores // c Numba threads (so -c 1 still uses every core)."""
    concurrency = getattr(sender, "concurrency", None)
    if "PRECOMPUTE_THREADS" in os.environ or not isinstance(concurrency, int) or concurrency < 1:
        return
    if "prefork" not in str(getattr(sender, "pool_cls", "")).lower():
        return
    os.environ["PRECOMPUTE_THREADS"] = str(max(1, (os.cpu_count() or 1) // concurrency))


def steps():
    """precompute.steps, the work itself: imported by a pool process at its first task, never by
    the worker's main process at boot (that module's docstring says why)."""
    return importlib.import_module(".steps", __package__)


def mark_running(job_id):
    """A task of the job starts: running, and a heartbeat the watchdog reads (precompute/watchdog.py)."""
    if job_id is None:
        return
    Job.objects.filter(pk=job_id).update(heartbeat_at=timezone.now())
    Job.objects.filter(pk=job_id, status=Job.PENDING).update(status=Job.RUNNING)


def record_part(job_id, key, index, computed, seconds=0.0, items=0, result=None):
    """Count one finished unit of the job, once per key (re-deliveries do not count twice)."""
    if job_id is None:
        return
    with transaction.atomic():
        if not Job.objects.filter(pk=job_id).exists():
            return
        _, created = Part.objects.get_or_create(
            job_id=job_id, key=key,
            defaults={"index": index, "computed": computed, "seconds": seconds, "items": items,
                      "worker": host_id(), "result": result or {}})
        if created:
            Job.objects.filter(pk=job_id).update(
                chunks_done=F("chunks_done") + 1,
                chunks_computed=F("chunks_computed") + int(computed),
                trajectories_computed=F("trajectories_computed") + int(items))


def finish_job(job_id, result=None, result_path=""):
    if job_id is None:
        return
    Job.objects.filter(pk=job_id).update(status=Job.SUCCEEDED, finished_at=timezone.now(), error="",
                                         error_detail="", result=result or {}, result_path=result_path,
                                         chunks_done=F("chunks_total"))
    log.info("precompute: job %s succeeded%s", job_id, f" -> {result_path}" if result_path else "")


def fail_job(job_id, exc, detail="", where="", in_words=False):
    """Mark the job failed with `exc`, its class named unless `in_words` (a refusal the researcher acts on)."""
    if job_id is None:
        return
    error = str(exc) if in_words else f"{where}{type(exc).__name__}: {exc}"
    Job.objects.filter(pk=job_id).update(status=Job.FAILED, finished_at=timezone.now(), error=error,
                                         error_detail=detail)
    log.warning("precompute: job %s failed: %s%s: %s", job_id, where, type(exc).__name__, exc)


def task_arguments(task, args, kwargs) -> dict:
    """A task's arguments by name, bound to its own signature (today's canvases send them all by
    keyword; a message sent by position by older code is named the same way)."""
    try:
        return dict(inspect.signature(task.run).bind_partial(*(args or ()), **(kwargs or {})).arguments)
    except (TypeError, ValueError):
        return dict(kwargs or {})


def _where(task_name, arguments: dict) -> str:
    """Which unit of the job failed, for the error line."""
    try:
        if task_name == "precompute.table_chunk":
            env_ids = arguments["env_ids"]
            return f"chunk {arguments['index']} (environments {env_ids[0]}..{env_ids[-1]}): "
        if task_name == "precompute.study_condition":
            return f"condition {arguments['name']}: "
        if task_name in ("precompute.publish_table", "precompute.study_finish"):
            return "final step: "
    except (KeyError, IndexError, TypeError):
        pass
    return ""


class JobTask(Task):
    """Marks the job failed, with the error, when a task of it fails for good."""

    acks_late = True
    reject_on_worker_lost = True

    def on_failure(self, exc, task_id, args, kwargs, einfo):
        arguments = task_arguments(self, args, kwargs)
        job_id = arguments.get("job_id")
        in_words = isinstance(exc, BuildRefused)  # the researcher's to change, not the code's
        detail = "" if in_words else str(einfo) if einfo else traceback.format_exc()
        try:
            fail_job(job_id, exc, detail, _where(self.name, arguments), in_words=in_words)
        except Exception:  # the failure must still reach the result backend
            log.exception("could not record the failure of job %s", job_id)


# --- trajectory tables ---------------------------------------------------------
@shared_task(base=JobTask, bind=True, name="precompute.table_chunk")
def table_chunk(self, job_id, spec, index, env_ids):
    """One chunk of environments, all thetas (the cross-theta step stays inside the chunk)."""
    mark_running(job_id)
    res = steps().compute_chunk(spec, env_ids, numba_threads())
    record_part(job_id, res["key"], index, res["computed"], res["seconds"], res["trajectories"])
    return {"index": index, **res}


@shared_task(base=JobTask, bind=True, name="precompute.publish_table")
def publish_table(self, job_id, spec):
    """Chord callback: check every chunk is stored, assemble, verify and publish the table."""
    mark_running(job_id)
    info = steps().publish(spec)
    finish_job(job_id, info, info["path"])
    return info


# --- study sequences -----------------------------------------------------------------
@shared_task(base=JobTask, bind=True, name="precompute.study_condition")
def study_condition(self, job_id, spec, name, index):
    """One condition: its teaching sequence, frozen on the study's Condition (training JSON).
    `spec`: the job's StudyJobSpec in its stored JSON form, any version."""
    spec = StudyJobSpec.from_json(spec)
    mark_running(job_id)
    condition = Condition.objects.get(study_id=spec.study_id, name=name)
    if condition.training and Part.objects.filter(job_id=job_id, key=name).exists():
        return {"condition": name, "computed": False}  # a re-delivery: already stored
    t0 = time.perf_counter()
    result = steps().select_condition(spec, condition)
    record_part(job_id, name, index, True, time.perf_counter() - t0, result=result)
    return {"condition": name, "computed": True, "env_ids": result["env_ids"]}


@shared_task(base=JobTask, bind=True, name="precompute.study_finish")
def study_finish(self, job_id, spec):
    """Chord callback: the test set (disjoint from every condition's training) and the simulated
    pilot (stored with the study), then open the study if asked."""
    spec = StudyJobSpec.from_json(spec)
    mark_running(job_id)
    study = Study.objects.get(pk=spec.study_id)
    conditions = [c for c in study.conditions.all() if c.name not in spec.closed_loop]
    empty = [c.name for c in conditions if not c.training]
    if empty:
        raise RuntimeError(f"conditions without a training sequence: {', '.join(empty)}; retry the job")
    t0 = time.perf_counter()
    tests, loops, from_fit = steps().finish_study(job_id, spec, study, conditions)
    record_part(job_id, "test-set", len(conditions), True, time.perf_counter() - t0,
                result={"env_ids": [t["env_id"] for t in tests]})
    kept = ("env_ids", "selector", "params", "value", "rule_met", "p")
    summary = {"study_slug": study.slug, "study_id": study.pk, "test_env_ids": [t["env_id"] for t in tests],
               "conditions": {p.key: {k: p.result.get(k) for k in kept}
                              for p in Part.objects.filter(job_id=job_id).exclude(key="test-set")},
               "closed_loop": {name: {"checks": [t["env_id"] for t in data["checks"]], "eligible": data["eligible"],
                                      "settings": data["settings"], "from_fit": from_fit.get(name, "")}
                               for name, data in loops.items()}}
    finish_job(job_id, summary)
    return {"study": study.slug, "tests": summary["test_env_ids"]}


# --- the teaching benchmark ------------------------------------------------------------
@shared_task(bind=True, name="precompute.benchmark_cells", acks_late=True, reject_on_worker_lost=True)
def benchmark_cells(self, table, cells, out):
    """One shared selection of the teaching benchmark (a selector, its parameters, a seed) with every learner's
    cell: teaching/benchmark/run.py's run_batch, writing each result to the results folder `out` (on a filesystem
    every worker shares, as a table's).  A re-delivery reads the cells already written instead of computing them."""
    run = importlib.import_module("teaching.benchmark.run")  # imported at the first task, as steps() is
    return {**run.run_batch(table, cells, out), "host": host_id()}
