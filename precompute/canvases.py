"""The Celery canvas of each kind of job, in one place.

Table: ``chord([table_chunk × n_chunks], publish_table)``.  Study:
``chord([study_condition × n_conditions], study_finish)`` (the test set must
avoid every training environment, so it comes after the conditions).

Kept apart from jobs.py (which sends them) and study.py (which creates study
jobs) so that neither has to import the other to build a canvas.
"""
from __future__ import annotations

from celery import Signature, chord

from . import work
from .specs import StudyJobSpec
from .tasks import default_queue, publish_table, study_condition, study_finish, table_chunk


def sig(task, *, queue: str, app=None, **kwargs) -> Signature:
    """`task`(**kwargs) on `queue`, sent through `app` (default: the task's own).  By keyword,
    never by position: a task's arguments can be renamed or reordered without a stored or queued
    message being decoded as something else.  Immutable: a chord's members and its callback take
    their arguments from the job, never from each other."""
    return Signature(task.name, kwargs=kwargs, immutable=True, options={"queue": queue}, app=app or task.app)


def table_canvas(job_id, spec, queue=None, app=None):
    """chord(one table_chunk per chunk, publish_table).  `app`: send through another Celery
    app (e.g. one pointed at another broker) than the project's."""
    queue = queue or default_queue()
    header = [sig(table_chunk, job_id=job_id, spec=spec, index=i, env_ids=ids, queue=queue, app=app)
              for i, ids in enumerate(work.chunk_ids(spec))]
    return chord(header, sig(publish_table, job_id=job_id, spec=spec, queue=queue, app=app),
                 app=app or table_chunk.app)


def study_canvas(job_id, spec: StudyJobSpec, queue=None):
    """chord(one study_condition per condition, study_finish) for a study job's typed spec; the
    tasks get the spec in its stored JSON form (precompute/specs.py reads it back)."""
    queue = queue or default_queue()
    payload = spec.to_json()
    header = [sig(study_condition, job_id=job_id, spec=payload, name=name, index=i, queue=queue)
              for i, name in enumerate(spec.conditions)]
    return chord(header, sig(study_finish, job_id=job_id, spec=payload, queue=queue), app=study_condition.app)
