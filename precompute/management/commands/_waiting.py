"""Shared by the commands that start a job and may --wait for it (not a command: leading underscore)."""
import sys

from django.core.management.base import CommandError

from precompute import jobs


def wait_for_job(command, job, opts):
    """Block with a progress bar until `job` ends; a timeout, Ctrl-C or a failed job is a CommandError."""
    try:
        job = jobs.wait(job, progress=not opts["no_progress"], timeout=opts["timeout"],
                        stream=getattr(command.stderr, "_out", sys.stderr))
    except TimeoutError as exc:
        raise CommandError(str(exc)) from None
    except KeyboardInterrupt:
        raise CommandError(f"stopped waiting; job {job.pk} goes on in the workers") from None
    if job.status == job.FAILED:
        raise CommandError(f"job {job.pk} failed: {job.error}")
    return job
