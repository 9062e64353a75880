"""What a build that refuses leaves behind, as the job-failure tests check it: one line on the job page in
the researcher's words (no traceback, no exception's name), and a study that stays closed."""
from __future__ import annotations

from precompute.models import Job
from studyapp.models import Study


def assert_refused_in_one_line(job: Job, staff_client, slug: str, exception: str, shown: str) -> None:
    """``job`` failed in one line that names no ``exception`` class, its page shows ``shown`` and no
    traceback, and study ``slug`` is closed with a reason it cannot run."""
    assert job.status == Job.FAILED and job.error_detail == ""
    assert "\n" not in job.error and exception not in job.error
    page = staff_client.get(job.get_absolute_url()).content.decode()
    assert shown in page and "Traceback" not in page
    study = Study.objects.get(slug=slug)
    assert not study.is_open and study.running_problems()
