"""Participant views: entry link, the current step, answers, completion."""
from __future__ import annotations

import logging
from functools import wraps

from django.http import Http404, JsonResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.utils import timezone
from django.utils.translation import gettext
from django.utils.translation import gettext_lazy as _
from django.views.decorators.cache import never_cache
from django.views.decorators.clickjacking import xframe_options_exempt
from django.views.decorators.csrf import csrf_exempt
from django.views.decorators.http import require_GET, require_POST

from .. import status
from ..guards import security
from ..i18n import participant_texts
from ..language import in_study_language
from ..models import Participant, Study
from ..scenes import recording, scene_context
from ..trajectories import study_domain
from . import devices, flow, outcomes
from .assignment import StudyClosed, assign
from .pages import page_for
from .platforms import MTURK_HOSTS, completion_target, mturk_submit_base

logger = logging.getLogger(__name__)

MTURK_PREVIEW = "ASSIGNMENT_ID_NOT_AVAILABLE"
ID_MAX = 100
SUBMIT_TO_MAX = Participant._meta.get_field("turk_submit_to").max_length


MTURK_ORIGINS = " ".join(f"https://{host}" for host in sorted(MTURK_HOSTS))
FRAME_ANCESTORS = f"frame-ancestors 'self' {MTURK_ORIGINS}"
# Scripts only from this site's own files (no inline script, no eval), forms post only here or back
# to MTurk, nothing loaded from elsewhere.  Inline style attributes stay allowed (the progress bar's
# width); the scene data are <script type="application/json"> blocks, which are never executed.
PARTICIPANT_CSP = "; ".join([
    "default-src 'self'", "script-src 'self'", "style-src 'self' 'unsafe-inline'", "img-src 'self' data:",
    "media-src 'self' blob:",  # a robot's videos, preloaded whole and played from blob: URLs
    "object-src 'none'", "base-uri 'none'",
    f"form-action 'self' {MTURK_ORIGINS}",
    FRAME_ANCESTORS,
])


def participant_page(view):
    """Participant pages may be framed by Mechanical Turk (ExternalQuestion HITs show them in an
    iframe) but by nobody else: no X-Frame-Options, a CSP frame-ancestors list instead, in a policy
    that also allows only this site's own scripts (PARTICIPANT_CSP)."""
    @wraps(view)
    def wrapped(request, *args, **kwargs):
        response = view(request, *args, **kwargs)
        response["Content-Security-Policy"] = PARTICIPANT_CSP
        return response

    return xframe_options_exempt(never_cache(wrapped))


def _unavailable(request, study: Study):
    """The page of a study that cannot run on this server (Study.running_problems: its robot is not
    registered here, or its build never gave it test questions), or None when it can run.  Every participant
    view asks it with the study it has already read, before writing anything: the participant reads one
    clear page in the study's language (503), the researchers read why on the dashboard."""
    problems = study.running_problems()
    if not problems:
        return None
    logger.warning("study %r cannot run: %s", study.slug, problems[0])
    message = gettext("This study is not available right now. Please come back later, or return it "
                      "if you were recruited for it; the researchers can see why on their dashboard.")
    if security.wants_json(request):
        return JsonResponse({"ok": False, "error": message}, status=503)
    return render(request, "studyapp/unavailable.html", {"study": study, "message": message}, status=503)


def _session_key(study: Study) -> str:
    return f"participant:{study.slug}"


def _platform_ids(request):
    """(platform, pid, extra fields) from the entry link's query string; raises ValueError."""
    q = request.GET
    values = {k: q.get(k, "").strip() for k in
              ("PROLIFIC_PID", "STUDY_ID", "SESSION_ID", "workerId", "assignmentId", "hitId", "turkSubmitTo")}
    if any(len(v) > ID_MAX for k, v in values.items() if k != "turkSubmitTo"):
        raise ValueError(gettext("platform ids are at most {n} characters").format(n=ID_MAX))
    if values["PROLIFIC_PID"]:
        return Participant.PROLIFIC, values["PROLIFIC_PID"], {
            "platform_study_id": values["STUDY_ID"], "platform_session_id": values["SESSION_ID"]}
    if values["workerId"]:
        submit_to = values["turkSubmitTo"]
        if len(submit_to) > SUBMIT_TO_MAX:  # the column's length: longer would fail in PostgreSQL
            raise ValueError(gettext("turkSubmitTo is at most {n} characters").format(n=SUBMIT_TO_MAX))
        return Participant.MTURK, values["workerId"], {
            "platform_study_id": values["hitId"], "platform_session_id": values["assignmentId"],
            "turk_submit_to": mturk_submit_base(submit_to)}
    return Participant.ANONYMOUS, "", {}


@participant_page
@in_study_language
@require_GET
@security.rate_limit("RATE_LIMIT_ENTRY", by="ip")
def entry(request, slug):
    study = get_object_or_404(Study, slug=slug)
    unavailable = _unavailable(request, study)
    if unavailable is not None:
        return unavailable
    if request.GET.get("assignmentId") == MTURK_PREVIEW:
        return render(request, "studyapp/mturk_preview.html",
                      {"study": study, "summary": participant_texts(study_domain(study)).summary})
    try:
        platform, pid, ids = _platform_ids(request)
    except ValueError as exc:
        return render(request, "studyapp/error.html", {"study": study, "message": str(exc)}, status=400)
    if platform == Participant.PROLIFIC and not study.completion_code.strip():
        # Prolific accepts only its study's own code: a per-participant code would leave them unpaid.
        return render(request, "studyapp/error.html", {"study": study, "message": gettext(
            "This study is not ready for Prolific participants yet (it has no completion code). "
            "Please return it on Prolific; the researchers have been shown why.")}, status=503)
    if platform == Participant.ANONYMOUS:
        token = request.session.get(_session_key(study))
        known = Participant.objects.filter(study=study, token=token).first() if token else None
        if known:
            return redirect(known)
    try:
        participant = assign(study, platform, pid, **ids)
    except StudyClosed:
        return render(request, "studyapp/closed.html", {"study": study}, status=403)
    request.session[_session_key(study)] = participant.token
    return redirect(participant)


def _participant(slug: str, token: str) -> Participant:
    participant = (Participant.objects.select_related("study", "condition")
                   .filter(token=token).first())
    if participant is None or participant.study.slug != slug:
        raise Http404("This participant link does not belong to this study.")
    return participant


@participant_page
@in_study_language
@require_GET
def step(request, slug, token):
    participant = _participant(slug, token)
    unavailable = _unavailable(request, participant.study)
    if unavailable is not None:
        return unavailable
    Participant.objects.filter(pk=participant.pk).update(last_seen_at=timezone.now())
    if outcomes.check_time(participant):  # returned, timed out or screened out: the page of that outcome
        return render(request, "studyapp/ended.html", ended_context(participant))
    current = flow.current_step(participant)
    page = page_for(participant.study, current.kind)
    ctx = step_context(participant, current)
    if request.GET.get("moved"):
        ctx["notice"] = gettext(flow.MOVED_ON)
    # a failed comprehension check: the instructions again, its questions only when asked for
    ctx["reviewing"] = bool(ctx.get("missed_questions")) and not request.GET.get("questions")
    return page.render(request, ctx)


@require_GET
def media(request, slug, token, name):
    """A recording the participant's pages show (their own link's, so it works where a recruiting platform's
    frame keeps no cookie).  Its name is its content's hash, so their browser may keep it for good."""
    response = recording(_participant(slug, token).study, name)
    response["Cache-Control"] = "private, max-age=31536000, immutable"
    return response


def step_context(participant: Participant, current: flow.Step) -> dict:
    """What the step's page is given: what every page shows (the study, the progress bar, the numbers of
    examples and tests) and what its kind's page adds (studyapp.participant.pages)."""
    page = page_for(participant.study, current.kind)
    ctx = {
        "study": participant.study, "participant": participant, "step": current,
        "progress": round(100 * current.index / max(flow.planned_steps(participant) - 1, current.index, 1)),
        "total_training": len(participant.condition.training),
        "total_tests": len(participant.study.test_set),
    }
    loop = participant.condition.closed_loop
    if loop:  # closed loop: examples are chosen as the participant goes, up to a most
        ctx["total_training"] = gettext("up to {n}").format(n=loop["settings"]["max_examples"])
    if page.draws_robot:
        # the domain's scene module, palette, legend, texts, and where its recordings are served to this participant
        ctx.update(scene_context(participant.study, media_base=participant.get_absolute_url() + "media/"))
    ctx.update(page.context(participant, current, ctx))
    return ctx


ENDED_PAGES = {  # outcome: (title, what happened), as the participant reads them
    status.RETURNED: (_("You returned this study"), _("Your recruiting platform told us that you returned this "
                      "study, so it has ended for you. Nothing more is needed; you may close this page.")),
    status.TIMED_OUT: (_("Your time for this study is up"), _("This study had to be finished within {minutes} "
                       "minutes of starting it, and that time has passed, so your place has been given to someone "
                       "else. The answers you gave are kept.")),
    status.SCREENED_OUT: (_("Thank you for your time"), _("Your answers to the questions about the instructions "
                          "did not match them, so the study ends here for you. The answers you gave are kept.")),
}


def ended_context(participant: Participant) -> dict:
    title, text = ENDED_PAGES[participant.outcome]
    ctx = {"study": participant.study, "participant": participant, "title": str(title),
           "text": str(text).format(minutes=participant.study.time_limit_minutes),
           "code": "" if participant.outcome == status.RETURNED else participant.completion_code}
    if ctx["code"]:
        ctx.update(completion_target(participant))
    return ctx


# csrf_exempt only hands the CSRF check from the global middleware to framed_csrf_protect: inside
# MTurk's cross-site iframe the (SameSite=Lax) CSRF cookie is never sent, and Django's check would
# refuse every answer there; without the cookie the browser's Origin must be this site instead.
@csrf_exempt
@participant_page
@in_study_language
@require_POST
@security.rate_limit("RATE_LIMIT_ANSWER_IP", by="ip")
@security.rate_limit("RATE_LIMIT_ANSWER", by="token")
@security.framed_csrf_protect
def answer(request, slug, token, step_index):
    if request.POST.get("consent") == "no":
        declined = _decline(request, slug, token, step_index)
        if declined is not None:
            return declined
    participant = _participant(slug, token)
    unavailable = _unavailable(request, participant.study)
    if unavailable is not None:
        return unavailable
    if "consent" in request.POST:
        refused = _refuse_device(request, participant, step_index)
        if refused is not None:
            return refused
    try:
        participant = flow.record(participant, step_index, request.POST)
    except flow.AnswerError as exc:
        if exc.moved:  # an out-of-date page: back to where the participant is, saying why
            current = f"{participant.get_absolute_url()}?moved=1"
            if security.wants_json(request):
                return JsonResponse({"ok": False, "error": exc.message, "moved": True, "next": current},
                                    status=exc.status)
            return redirect(current)
        if security.wants_json(request):
            return JsonResponse({"ok": False, "error": exc.message}, status=exc.status)
        return render(request, "studyapp/error.html", {
            "study": participant.study, "participant": participant, "message": exc.message}, status=exc.status)
    if security.wants_json(request):
        return JsonResponse({"ok": True, "position": participant.position, "next": participant.get_absolute_url()})
    return redirect(participant.get_absolute_url(), permanent=False)


def _refuse_device(request, participant: Participant, step_index: int):
    """The refusal page if the participant's device may not take part (studyapp.participant.devices); None otherwise.
    They are deleted as one who declines is (flow.decline), so no place is kept, and the refusal is counted."""
    try:
        message = devices.problem(participant.study, request.POST, request.META.get("HTTP_USER_AGENT", ""))
    except devices.ReportError:  # no page sends it: refused as bad input, nothing stored or deleted
        message = gettext("The page's report of your screen could not be read; please reload the page.")
        if security.wants_json(request):
            return JsonResponse({"ok": False, "error": message}, status=400)
        return render(request, "studyapp/error.html", {"study": participant.study, "participant": participant,
                                                       "message": message}, status=400)
    if message is None or not flow.decline(participant, step_index):
        return None
    devices.count_refusal(participant.study)
    request.session.pop(_session_key(participant.study), None)
    if security.wants_json(request):
        return JsonResponse({"ok": False, "error": message}, status=403)
    return render(request, "studyapp/device_refused.html", {"study": participant.study, "message": message},
                  status=403)


def _decline(request, slug, token, step_index):
    """The declined page if this "I do not agree" deleted the participant (flow.decline), else None.

    The browser's session remembers the (random, now meaningless) token, so a double click shows the
    same page instead of "unknown link"; no row refers to it any more."""
    study = get_object_or_404(Study, slug=slug)
    unavailable = _unavailable(request, study)
    if unavailable is not None:
        return unavailable
    participant = Participant.objects.filter(token=token, study=study).first()
    if participant is None:
        if request.session.get(f"declined:{study.slug}") != token:
            raise Http404("This participant link does not belong to this study.")
    elif not flow.decline(participant, step_index):
        return None
    request.session.pop(_session_key(study), None)
    request.session[f"declined:{study.slug}"] = token
    return render(request, "studyapp/declined.html", {"study": study})


def home(request):
    if request.user.is_staff:
        return redirect("dashboard")
    return render(request, "studyapp/home.html", {"studies": Study.objects.filter(is_open=True)})

