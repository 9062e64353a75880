"""The Celery canvas of each kind of job, in one place.

Table: ``chord([table_chunk × n_chunks], publish_table)``.  Study:
``chord([study_condition × n_conditions], study_finish)`` (the test set must
avoid every training environment, so it comes after the conditions).

Kept apart from jobs.py (which sends them) and study.py (which creates study
jobs) so that neither has to import the other to build a canvas.
"""
from __future__ import annotations

from celery import Signature, chord
from django.conf import settings

from . import work
from .tasks import publish_table, study_condition, study_finish, table_chunk


def default_queue() -> str:
    return getattr(settings, "PRECOMPUTE_QUEUE", None) or "celery"


def sig(task, *args, queue: str, app=None) -> Signature:
    """`task`(*args) on `queue`, sent through `app` (default: the task's own).  Immutable: a
    chord's members and its callback take their arguments from the job, never from each other."""
    return Signature(task.name, args=args, immutable=True, options={"queue": queue}, app=app or task.app)


def table_canvas(job_id, spec, queue=None, app=None):
    """chord(one table_chunk per chunk, publish_table).  `app`: send through another Celery
    app (e.g. one pointed at another broker) than the project's."""
    queue = queue or default_queue()
    header = [sig(table_chunk, job_id, spec, i, ids, queue=queue, app=app)
              for i, ids in enumerate(work.chunk_ids(spec))]
    return chord(header, sig(publish_table, job_id, spec, queue=queue, app=app), app=app or table_chunk.app)


def study_canvas(job, queue=None):
    """chord(one study_condition per condition, study_finish) for a study Job."""
    queue = queue or default_queue()
    params = job.params
    header = [sig(study_condition, job.pk, params, name, i, queue=queue) for i, name in enumerate(params["conditions"])]
    return chord(header, sig(study_finish, job.pk, params, queue=queue), app=study_condition.app)
