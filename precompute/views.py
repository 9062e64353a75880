"""Job pages for staff: a list, and a job page that refreshes itself with progress,
throughput, ETA and the error of a failed job, with a retry button (POST, staff only); and the
study designer, which starts a study job (precompute/design.py)."""
from __future__ import annotations

from datetime import timedelta

from django.contrib import messages
from django.db.models import Max
from django.http import JsonResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.utils import timezone
from django.views.decorators.http import require_POST

from studyapp.guards.access import researcher_required
from studyapp.models import Study
from teaching.api import TableError

from . import designlayout, jobs, supply
from .design import StudyDesignForm
from .jobs import tables_dir
from .models import Job
from .specs import SpecFormatError
from .study import StudyJobError, create_study_job
from .tables import TableBuildForm, built_tables
from .work import ChunkError

REFRESH_SECONDS = 3
STALLED_AFTER = timedelta(minutes=5)  # no unit finished for this long: say so, offer Relaunch


def stalled_for(job: Job):
    """How long a pending/running job has gone without finishing a unit (None if it is moving)."""
    if job.finished or not job.started_at:
        return None
    last = job.parts.filter(finished_at__gte=job.started_at).aggregate(m=Max("finished_at"))["m"]
    quiet = timezone.now() - (last or job.started_at)
    return quiet if quiet >= STALLED_AFTER else None


def job_context(job: Job) -> dict:
    return {
        "id": job.pk, "kind": job.kind, "label": job.label, "status": job.status,
        "chunks_done": job.chunks_done, "chunks_total": job.chunks_total, "percent": job.percent,
        "chunks_computed": job.chunks_computed, "chunks_done_at_start": job.chunks_done_at_start,
        "throughput": round(job.throughput, 1) if job.throughput else None,
        "eta": jobs.format_seconds(job.eta_seconds) if job.eta_seconds is not None else None,
        "elapsed": jobs.format_seconds(job.elapsed) if job.elapsed is not None else None,
        "error": job.error, "alarm": job.alarm, "finished": job.finished, "attempts": job.attempts,
        "result_path": job.result_path, "result": job.result,
        "stalled_minutes": int(stalled.total_seconds() // 60) if (stalled := stalled_for(job)) else None,
    }


@researcher_required
def job_list(request):
    return render(request, "precompute/job_list.html", {"jobs": Job.objects.all()[:100]})


@researcher_required
def job_detail(request, pk):
    job = get_object_or_404(Job, pk=pk)
    parts = job.parts.order_by("-finished_at")[:20]
    return render(request, "precompute/job_detail.html",
                  {"job": job, "info": job_context(job), "parts": parts, "refresh": REFRESH_SECONDS})


@researcher_required
def job_status(request, pk):
    return JsonResponse(job_context(get_object_or_404(Job, pk=pk)))


@researcher_required
@require_POST
def job_retry(request, pk):
    job = get_object_or_404(Job, pk=pk)
    try:
        jobs.retry(job)
    except (jobs.BrokerUnavailable, SpecFormatError) as exc:  # the job is marked failed with it too
        messages.error(request, f"Job {job.pk} cannot be relaunched: {exc}")
    else:
        messages.success(request, f"Job {job.pk} relaunched: finished work is skipped.")
    return redirect(job.get_absolute_url())


@researcher_required
def design(request):
    """The study designer: a built table, conditions and settings -> a study job on the workers."""
    tables = built_tables()
    form = StudyDesignForm(request.POST or None, tables=tables)
    if request.method == "POST" and form.is_valid():
        d = form.cleaned_data
        try:
            job = create_study_job(d["table"], d["job"], start=False)
        except StudyJobError as exc:  # what only the table or the database says: under its field where it has one
            form.add_error(exc.field if exc.field in form.fields else None, str(exc))
        except TableError as exc:
            form.add_error("table", str(exc))
        else:
            return launch_and_follow(request, job, f"Building study {d['slug']!r} on the workers: when this job "
                                     "is done, preview its conditions on the study's page, then open it.")
    return render(request, "precompute/design.html", design_context(form=form, tables=tables))


@researcher_required
def design_supply(request):
    """How many environments of a published table could hold each test, per difficulty level (JSON, for the
    designer's page beside the test fields): ?table=PATH&kind=choose|show[&min_regret=X&min_distance=Y]."""
    path = request.GET.get("table", "")
    if path not in {t["path"] for t in built_tables()}:
        return JsonResponse({"error": "Not a table the designer lists."}, status=404)
    kind = request.GET.get("kind") or Study.CHOOSE
    try:
        thresholds = [float(v) if v.strip() else None for v in
                      (request.GET.get("min_regret", ""), request.GET.get("min_distance", ""))]
        if kind not in (Study.CHOOSE, Study.SHOW) or any(v is not None and not v >= 0 for v in thresholds):
            raise ValueError
    except ValueError:
        return JsonResponse({"error": "Give a test kind (choose or show) and thresholds of 0 or more."}, status=400)
    try:
        return JsonResponse(supply.counts(path, kind, *thresholds))
    except (TableError, OSError, ValueError) as exc:
        return JsonResponse({"error": f"Cannot read this table: {exc}"}, status=400)


def design_context(**ctx) -> dict:
    """The designer page: the study form, the table-build form and the table jobs under way."""
    ctx.setdefault("tables", built_tables())
    ctx.setdefault("form", StudyDesignForm(tables=ctx["tables"]))
    ctx.setdefault("table_form", TableBuildForm())
    ctx["sections"] = designlayout.sections(ctx["form"])
    ctx["table_jobs"] = Job.objects.filter(kind=Job.TABLE).exclude(status__in=(Job.SUCCEEDED,))[:10]
    # study jobs the watchdog relaunched or failed (precompute/watchdog.py): the researcher must see it
    ctx["alarmed_jobs"] = Job.objects.exclude(kind=Job.TABLE).exclude(alarm="").exclude(status=Job.SUCCEEDED)[:10]
    ctx["tables_dir"] = tables_dir()
    return ctx


@researcher_required
@require_POST
def design_table(request):
    """Start a table build on the workers; its job page shows the progress, and the designer lists
    the table once it is published."""
    form = TableBuildForm(request.POST)
    if not form.is_valid():
        return render(request, "precompute/design.html", design_context(table_form=form), status=400)
    preset = form.cleaned_data["built"]
    try:
        job = jobs.create_table_job(preset, tables_dir() / preset.name, start=False)
    except ChunkError as exc:
        form.add_error(None, str(exc))
        return render(request, "precompute/design.html", design_context(table_form=form), status=400)
    return launch_and_follow(request, job, f"Building table {preset.name!r} on the workers: when this job is done, "
                             "the designer lists it.")


def launch_and_follow(request, job: Job, started: str):
    """Send a new job's canvas and show its page, saying `started`, or the broker's error (the job
    is then marked failed with it, and its page has Retry)."""
    try:
        jobs.launch(job)
    except jobs.BrokerUnavailable as exc:
        messages.error(request, str(exc))
    else:
        messages.success(request, started)
    return redirect(job)
