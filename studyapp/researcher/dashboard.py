"""Researcher views: study list, per-study dashboard with live progress, its simulated pilot
(studyapp/researcher/pilot.py), open/close, preview, exports, marking who returned the study, erasing a
participant's data."""
from __future__ import annotations

from django.contrib import messages
from django.db.models import Count, Q
from django.http import HttpResponse, StreamingHttpResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.utils import timezone
from django.views.decorators.http import require_POST

from .. import status
from ..data import exports, privacy
from ..guards.access import researcher_required
from ..models import Answer, ComprehensionAttempt, Condition, Participant, Study
from ..participant import bonuses, outcomes
from ..participant.assignment import counted_filter, preview_participant
from . import durations
from .leaderboard import leaderboard_context
from .pilot import pilot_context

REFRESH_SECONDS = 5


ENDED_COLUMNS = (status.RETURNED, status.TIMED_OUT, status.SCREENED_OUT)


def condition_stats(study: Study) -> list[dict]:
    now = timezone.now()
    outcomes.expire(study, now)  # who ran out of time is counted as timed out, not as in progress
    cutoff = now - study.active_timeout
    real = ~Q(participants__platform=Participant.PREVIEW)
    done = Q(participants__completed_at__isnull=False)
    going = real & ~done & Q(participants__outcome="")
    rows = study.conditions.annotate(  # each row's .study is `study`: target_count reads no other copy
        started=Count("participants", filter=real),
        completed=Count("participants", filter=real & done),
        excluded=Count("participants", filter=real & Q(participants__excluded=True)),
        active=Count("participants", filter=going & Q(participants__last_seen_at__gte=cutoff)),
        abandoned=Count("participants", filter=going & Q(participants__last_seen_at__lt=cutoff)),
        **{ended: Count("participants", filter=real & Q(participants__outcome=ended)) for ended in ENDED_COLUMNS},
        counted=Count("participants", filter=counted_filter(study, now)),
        # Valid = finished and kept: a participant who failed the attention check is excluded
        # whether or not they finished, so "completed - excluded" would undercount.
        valid=Count("participants", filter=Participant.complete_filter("participants__")),
    )
    return [{"condition": c, "target": c.target_count, "started": c.started, "completed": c.completed,
             "excluded": c.excluded, "active": c.active, "abandoned": c.abandoned, "counted": c.counted,
             "valid": c.valid, "percent": min(100, round(100 * c.valid / max(c.target_count, 1))),
             **{ended: getattr(c, ended) for ended in ENDED_COLUMNS}}
            for c in rows]


@researcher_required
def index(request):
    studies = Study.objects.annotate(
        n_participants=Count("participants", filter=~Q(participants__platform=Participant.PREVIEW)))
    return render(request, "studyapp/dashboard/index.html", {"studies": studies})


RECENT = 15  # lines of recent activity


def recent_activity(study) -> list[dict]:
    """The study's latest answers and comprehension attempts (a failed attempt writes no answer), newest
    first: {"at", "participant", "what"} each, "what" in words (a shown way: its moves and θ*-regret)."""
    real = ~Q(participant__platform=Participant.PREVIEW)
    answers = (Answer.objects.filter(real, participant__study=study)
               .select_related("participant", "participant__condition").order_by("-created_at")[:RECENT])
    attempts = (ComprehensionAttempt.objects.filter(real, participant__study=study)
                .select_related("participant", "participant__condition").order_by("-created_at")[:RECENT])
    out = []
    for a in answers:
        what = f"{a.kind}{'' if a.item is None else f' {a.item + 1}'}"
        if isinstance(a.data, dict) and "moves" in a.data:
            shown = a.data["moves"]
            moves = len(shown) if isinstance(shown, list) else len(str(shown).split())
            what += f", a way of {moves} move{'s' if moves != 1 else ''}"
            if a.regret is not None:
                what += f", θ*-regret {a.regret:.3g}"
        elif a.confidence_score is not None:
            what += f", score {a.confidence_score}"
        out.append({"at": a.created_at, "participant": a.participant, "what": what})
    for c in attempts:
        missed = f", missed {len(c.missed)}" if not c.passed else ""
        out.append({"at": c.created_at, "participant": c.participant,
                    "what": f"comprehension attempt {c.number}: {'passed' if c.passed else 'failed'}{missed}"})
    return sorted(out, key=lambda e: e["at"], reverse=True)[:RECENT]


def _progress_context(request, study):
    recent = recent_activity(study)
    stats = condition_stats(study)
    totals = {k: sum(r[k] for r in stats) for k in ("target", "started", "completed", "excluded", "active",
                                                    "abandoned", *ENDED_COLUMNS)}
    return {"study": study, "stats": stats, "totals": totals, "recent": recent, "now": timezone.now(),
            "refresh_seconds": REFRESH_SECONDS,
            "bonuses": bonuses.totals(study) if bonuses.offers_bonus(study) else None}


@researcher_required
def detail(request, slug):
    study = get_object_or_404(Study, slug=slug)
    ctx = _progress_context(request, study)
    link = request.build_absolute_uri(study.get_absolute_url())
    ctx.update(link=link, prolific_link=link + "?PROLIFIC_PID={{%PROLIFIC_PID%}}&STUDY_ID={{%STUDY_ID%}}"
               "&SESSION_ID={{%SESSION_ID%}}")
    ctx.update(pilot_context(study, request.GET))  # the simulated pilot: ideal users and the power table
    ctx.update(leaderboard_context(study))  # its table on the teaching leaderboard, beside the pilot
    found = durations.estimates(study)  # what each condition's participants go through, before anyone does
    ctx.update(experience=found, experience_warnings=durations.warnings(study, found),
               bonus_rule_researcher=bonuses.researcher_rule(study))
    return render(request, "studyapp/dashboard/detail.html", ctx)


@researcher_required
def progress(request, slug):
    """The auto-refreshed part of the dashboard (HTML fragment)."""
    study = get_object_or_404(Study, slug=slug)
    return render(request, "studyapp/dashboard/_progress.html", _progress_context(request, study))


@researcher_required
@require_POST
def toggle(request, slug):
    study = get_object_or_404(Study, slug=slug)
    opening = request.POST.get("open") == "1"
    problems = study.opening_problems() if opening else []
    for problem in problems:
        messages.error(request, problem)
    if problems:
        return redirect("dashboard_study", slug=slug)
    study.is_open = opening
    study.save(update_fields=["is_open"])
    return redirect("dashboard_study", slug=slug)


@researcher_required
@require_POST
def preview(request, slug, condition_id):
    condition = get_object_or_404(Condition, pk=condition_id, study__slug=slug)
    return redirect(preview_participant(condition))


@researcher_required
def export(request, slug, kind):
    """The long and wide files are streamed as they are written (a study of 10,000 participants
    would otherwise be built whole in the web worker); none is kept by a browser or proxy cache
    (Cache-Control: no-store from config.middleware.ResearcherNoStoreMiddleware, as on every
    researcher page)."""
    study = get_object_or_404(Study, slug=slug)
    if kind in exports.STREAMS:
        pseudonymise = request.GET.get("pseudonymise") == "1"  # for sharing: no platform id
        response = StreamingHttpResponse(exports.STREAMS[kind](study, pseudonymise),
                                         content_type="text/csv; charset=utf-8")
        name = f"{slug}-{kind}{'-pseudonymised' if pseudonymise else ''}.csv"
    elif kind == "bonuses-prolific":  # pasted into Prolific's bulk bonus box: "id,amount" lines, no header
        response = HttpResponse(bonuses.prolific_lines(study), content_type="text/csv; charset=utf-8")
        name = f"{slug}-bonuses-prolific.csv"
    elif kind == "bonuses-mturk":
        response = HttpResponse(bonuses.mturk_csv(study), content_type="text/csv; charset=utf-8")
        name = f"{slug}-bonuses-mturk.csv"
    else:
        response = HttpResponse(exports.dictionary_csv(study), content_type="text/csv; charset=utf-8")
        name = f"{slug}-data-dictionary.csv"
    response["Content-Disposition"] = f'attachment; filename="{name}"'
    return response


@researcher_required
@require_POST
def erase(request, slug):
    """A participant's data erased at their request (studyapp.data.privacy): a post with "find" shows what would
    go, the confirmation's post with "erase" erases it and returns to the dashboard saying what went.  Both
    are posts, so the platform id never appears in a URL (nor in an access log)."""
    study = get_object_or_404(Study, slug=slug)
    platform_id = request.POST.get("platform_id", "")
    try:
        if request.POST.get("action") == "erase":
            gone = privacy.erase(platform_id, study)
            messages.success(request, f"Erased {gone.summary()}.")
            return redirect("dashboard_study", slug=slug)
        found = privacy.find(platform_id, study)
    except privacy.ErasureError as exc:
        return render(request, "studyapp/dashboard/erase.html", {"study": study, "error": str(exc)}, status=404)
    return render(request, "studyapp/dashboard/erase.html", {"study": study, "found": found,
                                                             "platform_id": platform_id.strip()})


@researcher_required
@require_POST
def mark_returned(request, slug):
    """Participants the recruiting platform says returned the study (their ids pasted from its list of
    returned submissions): marked returned, their places freed (studyapp.participant.outcomes)."""
    study = get_object_or_404(Study, slug=slug)
    try:
        ids = outcomes.parse_ids(request.POST.get("platform_ids", ""))
    except ValueError as exc:
        messages.error(request, _sentence(str(exc)))
        return redirect("dashboard_study", slug=slug)
    if not ids:
        messages.error(request, "Paste the platform ids of the participants who returned the study.")
        return redirect("dashboard_study", slug=slug)
    report = outcomes.mark_returned(study, ids)
    (messages.success if report.marked else messages.error)(request, _sentence(report.summary()))
    return redirect("dashboard_study", slug=slug)


def _sentence(text: str) -> str:
    """A message as a sentence; the ids in it keep their case (str.capitalize would lower them)."""
    return text[:1].upper() + text[1:] + "."
