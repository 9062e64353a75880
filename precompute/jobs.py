"""Creating table jobs, (re)launching any job as its Celery canvas (precompute/canvases.py),
and waiting for one.

Re-launching a job (retry) sends the whole canvas again: chunks already
stored are skipped in a few milliseconds each, so only the missing ones are
computed.
"""
from __future__ import annotations

import logging
import time
from dataclasses import replace
from pathlib import Path

from django.conf import settings
from django.utils import timezone
from kombu.exceptions import OperationalError
from kombu.utils.url import maybe_sanitize_url
from tqdm import tqdm

from teaching.api import SAMPLERS, Preset, customised, get_domain, get_preset

from . import work
from .canvases import default_queue, study_canvas, table_canvas
from .models import Job, Part
from .specs import SpecFormatError, TableJobSpec, read_spec
from .tasks import fail_job

log = logging.getLogger(__name__)


def tables_dir() -> Path:
    """Where tables live: settings.TABLES_DIR ($TABLES_DIR, default $VAR_DIR/tables), the one
    definition the commands, the designer and the demo (studyapp/researcher/studies.py) all read."""
    return Path(settings.TABLES_DIR)


class BrokerUnavailable(RuntimeError):
    """The canvas could not be sent: the broker is down or misconfigured."""


def table_preset(name: str, *, envs=None, thetas=None, seed=None, sampler=None, theta_star=None,
                 chunk_size=None) -> Preset:
    """The named preset with overrides (None: unchanged; teaching's `customised` names a changed
    one).  ValueError with a one-line message for a bad value: the command and the designer's
    table form share these rules."""
    preset = get_preset(name)
    n_all = get_domain(preset.domain).n_environments  # the preset's domain's, not the default's
    if envs is not None and not 4 <= envs <= n_all:
        raise ValueError(f"the number of environments must lie in [4, {n_all:,}] ({preset.domain}), got {envs}")
    if thetas is not None and thetas < 2:
        raise ValueError(f"the number of thetas must be at least 2 (theta* and one other), got {thetas}")
    if sampler is not None and sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {sampler!r}; choose one of {', '.join(SAMPLERS)}")
    try:
        preset = customised(preset, n_envs=envs, n_thetas=thetas, seed=seed, sampler=sampler, theta_star=theta_star)
    except ValueError as exc:
        raise ValueError(f"theta*: {exc}") from None
    if chunk_size is not None:
        preset = replace(preset, chunk_size=chunk_size)
    return preset


def create_table_job(preset: Preset, out, queue=None, start: bool = True) -> Job:
    """A job that builds (or finishes building) `preset`'s table in directory `out`."""
    out = Path(out)
    work.check_writable(out.resolve())
    spec = work.table_spec(preset, out)
    params = TableJobSpec(preset=spec["preset"], out=spec["out"], queue=queue).to_json()
    job = Job.objects.create(kind=Job.TABLE, params=params, chunks_total=spec["n_chunks"])
    if start:
        launch(job)
    return job


def launch(job: Job, by_watchdog: bool = False) -> Job:
    """(Re)send the job's canvas; units already recorded stay counted.  The stored spec is read
    in whatever format it was written (precompute/specs.py upgrades it, and stores it back in
    today's); one this code cannot read fails the job with a SpecFormatError saying why."""
    try:
        spec = read_spec(job.kind, job.params)
        canvas = _canvas(job.pk, spec)
    except SpecFormatError as exc:
        fail_job(job.pk, exc, where="stored spec: ")
        job.refresh_from_db()
        raise
    job.params = spec.to_json()
    # Parts recorded by earlier launches stay counted; a chunk stored without its Part row
    # (another job built it, or a worker died between storing and recording) is counted
    # when this launch's task finds it stored.
    stored = job.parts.count()
    job.status, job.error, job.error_detail = Job.PENDING, "", ""
    job.chunks_done = job.chunks_done_at_start = stored
    job.chunks_computed = job.trajectories_computed = 0
    job.started_at, job.finished_at = timezone.now(), None
    job.attempts += 1
    if not by_watchdog:  # a person's launch: the watchdog's count and alarm start again
        job.watchdog_relaunches, job.alarm = 0, ""
    job.save()
    try:
        result = canvas.apply_async()
    except OperationalError as exc:  # the broker is unreachable: say so on the job and to the caller
        url = maybe_sanitize_url(canvas.app.conf.broker_url)
        error = BrokerUnavailable(f"cannot send job {job.pk} to the broker at {url}: {exc}")
        fail_job(job.pk, error)
        job.refresh_from_db()
        raise error from None
    Job.objects.filter(pk=job.pk).update(canvas_id=result.id or "")
    job.canvas_id = result.id or ""
    log.info("precompute: job %s (%s) launched, attempt %d, %d of %d parts already done", job.pk, job.label,
             job.attempts, stored, job.chunks_total)
    return job


def _canvas(job_id, spec):
    if isinstance(spec, TableJobSpec):
        try:
            preset = Preset(**spec.preset)
        except TypeError as exc:  # a preset field renamed or removed since the job was stored
            raise SpecFormatError(f"table job spec: its preset does not fit teaching's Preset: {exc}") from None
        return table_canvas(job_id, work.table_spec(preset, spec.out), spec.queue)
    return study_canvas(job_id, spec, spec.queue)


def retry(job: Job) -> Job:
    """Send the job again.  Safe at any time: stored chunks and frozen conditions are skipped,
    so relaunching a job that stalled (its worker was killed on the filesystem broker, or a
    Redis message waits for its visibility timeout) computes only what is missing."""
    return launch(job)


def format_seconds(s: float | None) -> str:
    if s is None:
        return "?"
    s = int(round(s))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def progress_text(job: Job) -> str:
    parts = []
    if job.throughput:
        parts.append(f"{job.throughput:,.0f} traj/s")
    if job.eta_seconds is not None:
        parts.append(f"ETA {format_seconds(job.eta_seconds)}")
    return ", ".join(parts)


def wait(job: Job, progress: bool = True, poll: float = 0.5, timeout: float | None = None, stream=None,
         hint_after: float = 20.0) -> Job:
    """Block until the job finishes, with a tqdm bar: chunks done / total, trajectories/s, ETA."""
    start = time.monotonic()
    job.refresh_from_db()
    unit = "chunk" if job.kind == Job.TABLE else "part"
    bar = tqdm(total=job.chunks_total, initial=job.chunks_done, unit=unit, disable=not progress, file=stream,
               desc=job.label, dynamic_ncols=True,
               bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} " + unit + "s [{elapsed}{postfix}]")
    hinted = False
    try:
        while True:
            job.refresh_from_db()
            if job.chunks_done > bar.n:
                bar.update(job.chunks_done - bar.n)
            bar.set_postfix_str(progress_text(job), refresh=False)
            bar.refresh()
            if job.finished:
                return job
            waited = time.monotonic() - start
            if not hinted and job.status == Job.PENDING and waited > hint_after:
                bar.write("no progress yet: is a worker running?  celery -A config worker -l info")
                hinted = True
            if timeout is not None and waited > timeout:
                raise TimeoutError(f"job {job.pk} still {job.status} after {timeout:.0f} s")
            time.sleep(poll)
    finally:
        bar.close()


__all__ = ["create_table_job", "launch", "retry", "wait", "default_queue", "table_canvas", "Part"]
