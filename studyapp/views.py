"""Participant views: entry link, the current step, answers, completion."""
from __future__ import annotations

import logging
from functools import wraps
from urllib.parse import urlsplit

from django.http import Http404, JsonResponse
from django.shortcuts import get_object_or_404, redirect, render
from django.utils import timezone
from django.utils.translation import gettext
from django.utils.translation import gettext_lazy as _
from django.views.decorators.cache import never_cache
from django.views.decorators.clickjacking import xframe_options_exempt
from django.views.decorators.csrf import csrf_exempt
from django.views.decorators.http import require_GET, require_POST

from . import bonuses, closedloop, comprehension, devices, flow, forms, outcomes, security, status
from .assignment import StudyClosed, assign
from .i18n import domain_text, in_study_language, participant_texts
from .models import LoopStep, Participant, StepKind, Study
from .scenes import instructions, scene_context
from .trajectories import drawn_scene, study_domain

logger = logging.getLogger(__name__)

MTURK_PREVIEW = "ASSIGNMENT_ID_NOT_AVAILABLE"
MTURK_HOSTS = {"www.mturk.com", "workersandbox.mturk.com"}
ID_MAX = 100
SUBMIT_TO_MAX = Participant._meta.get_field("turk_submit_to").max_length


MTURK_ORIGINS = " ".join(f"https://{host}" for host in sorted(MTURK_HOSTS))
FRAME_ANCESTORS = f"frame-ancestors 'self' {MTURK_ORIGINS}"
# Scripts only from this site's own files (no inline script, no eval), forms post only here or back
# to MTurk, nothing loaded from elsewhere.  Inline style attributes stay allowed (the progress bar's
# width); the scene data are <script type="application/json"> blocks, which are never executed.
PARTICIPANT_CSP = "; ".join([
    "default-src 'self'", "script-src 'self'", "style-src 'self' 'unsafe-inline'", "img-src 'self' data:",
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


def mturk_submit_base(raw: str) -> str:
    """The MTurk site a worker's answers go back to, from the link's `turkSubmitTo`: exactly
    "https://www.mturk.com" or "https://workersandbox.mturk.com", rebuilt from the allowlist (the
    page's form posts there), or "" when absent; anything else raises ValueError.

    Checking only `urlparse(x).hostname` let `javascript://www.mturk.com/%0A...` (script on this
    site) and `https://evil.example\\@www.mturk.com/` (a browser posts to evil.example) through:
    browsers parse URLs by the WHATWG rules, which strip tabs and newlines and read backslashes as
    slashes.  So: printable ASCII without backslashes only, https only, no user, password, port,
    path, query or fragment, and the stored value is the allowlisted one, never the raw input."""
    if not raw:
        return ""
    if any(not 0x21 <= ord(c) <= 0x7E or c == "\\" for c in raw):
        raise ValueError(gettext("turkSubmitTo must be a plain https://www.mturk.com address"))
    parts = urlsplit(raw)
    host = parts.netloc.lower()
    if (parts.scheme.lower() != "https" or host not in MTURK_HOSTS or parts.path not in ("", "/")
            or parts.query or parts.fragment):
        raise ValueError(gettext("turkSubmitTo must be https://www.mturk.com or https://workersandbox.mturk.com"))
    return f"https://{host}"


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
    ctx = step_context(participant, current)
    if request.GET.get("moved"):
        ctx["notice"] = gettext(flow.MOVED_ON)
    # a failed comprehension check: the instructions again, its questions only when asked for
    ctx["reviewing"] = bool(ctx.get("missed_questions")) and not request.GET.get("questions")
    return render(request, f"studyapp/step_{template_kind(participant, current)}.html", ctx)


def template_kind(participant: Participant, current: flow.Step) -> str:
    """The step's template: its kind's, but "show" for a test or check that asks to show the way."""
    if current.kind in (StepKind.TEST, StepKind.CHECK) and participant.study.test_kind == Study.SHOW:
        return "show"
    return current.kind


# Closed-loop conditions (studyapp.closedloop) add to the domain's instructions.
CHECK_INSTRUCTIONS = _("Between the examples you will sometimes answer a check question, just like the questions "
                       "at the end. Your answers decide which example you see next; they do not count towards "
                       "your score.")
# appended to CHECK_INSTRUCTIONS after a space (kept out of the catalog's text, so no translator loses it)
FEEDBACK_INSTRUCTIONS = _("After each check question you will see the right answer: what really happens there.")


def step_context(participant: Participant, current: flow.Step) -> dict:
    steps = flow.steps_for(participant)
    ctx = {
        "study": participant.study, "participant": participant, "step": current,
        "progress": round(100 * current.index / max(planned_steps(participant, steps) - 1, current.index, 1)),
        "total_training": len(participant.condition.training),
        "total_tests": len(participant.study.test_set),
    }
    # The page gets what it draws and nothing else (drawn_scene): no theta, cluster or option
    # index, and no reference trajectory, so its source cannot tell theta*'s option apart.
    domain = study_domain(participant.study)
    loop = participant.condition.closed_loop
    if loop:  # closed loop: examples are chosen as the participant goes, up to a most
        ctx["total_training"] = gettext("up to {n}").format(n=loop["settings"]["max_examples"])
    if current.kind == StepKind.CONSENT:
        ctx["bonus_rule"] = bonuses.rule_text(participant.study)  # what they are paid for, before they agree
        if participant.study.payment_amount is not None:  # money written one way on every page
            ctx["payment_amount"] = bonuses.participant_label(participant.study, participant.study.payment_amount)
        if participant.study.has_device_rules:
            ctx["device_rules"] = devices.rules(participant.study)
    if current.kind in (StepKind.INSTRUCTIONS, StepKind.COMPREHENSION, StepKind.TRAINING, StepKind.FEEDBACK,
                        StepKind.TEST, StepKind.CHECK):
        ctx.update(scene_context(participant.study))  # the domain's scene module, palette, legend, texts
    if current.kind == StepKind.COMPREHENSION:  # its page shows the instructions again after a failed attempt
        ctx.update(comprehension.page_context(participant))
    if current.kind in (StepKind.INSTRUCTIONS, StepKind.COMPREHENSION):
        ctx["instructions"] = instructions(participant.study, ctx["total_training"], ctx["total_tests"])
        if loop and loop["settings"]["check_every"]:
            ctx["instructions"].append(str(CHECK_INSTRUCTIONS) + (" " + str(FEEDBACK_INSTRUCTIONS)
                                                                  if loop["settings"]["feedback"] else ""))
    elif current.kind in (StepKind.TRAINING, StepKind.FEEDBACK):
        if loop:
            shown = [s.payload for s in participant.loop_steps.filter(index__lte=current.item, kind=LoopStep.EXAMPLE)]
            payload = participant.loop_steps.get(index=current.item).payload
            training, item = shown, len(shown) - 1
        else:
            training, item = participant.condition.training, current.item
            payload = training[item]
        ctx["caption"] = caption_of(domain, payload)
        ctx["env"] = drawn_scene(payload, robot=True, domain=domain)
        ctx["number"] = item + 1
        if current.kind == StepKind.TRAINING:
            ctx["seen_before"] = repeated_example(training, item)
    elif current.kind in (StepKind.TEST, StepKind.CHECK) and participant.study.test_kind == Study.SHOW:
        test = flow.question_of(participant, current.kind, current.item)
        ctx["number"] = (participant.loop_steps.filter(index__lte=current.item, kind=LoopStep.CHECK).count()
                         if current.kind == StepKind.CHECK else current.item + 1)
        ctx["caption"] = caption_of(domain, test)
        ctx["scene"] = drawn_scene(test, robot=False, domain=domain)  # never θ*'s way
        rules = domain.show_rules(test["env_id"])
        ctx["rules"] = {**rules, "object": domain_text(domain, rules["object"])}  # the page says its name
        ctx["endings"] = show_endings(ctx["scene"], ctx["rules"])
    elif current.kind in (StepKind.TEST, StepKind.CHECK):
        test = flow.question_of(participant, current.kind, current.item)
        shown = flow.option_letters(participant, current.item, current.kind)
        ctx["number"] = (participant.loop_steps.filter(index__lte=current.item, kind=LoopStep.CHECK).count()
                         if current.kind == StepKind.CHECK else current.item + 1)
        ctx["caption"] = caption_of(domain, test)
        ctx["scene"] = drawn_scene(test, robot=False, domain=domain)
        ctx["options"] = [letter for letter, _ in shown]
        ctx["option_robots"] = {letter: test["options"][k]["robot"] for letter, k in shown}
        ctx["ratings"] = range(forms.RATING_MIN, forms.RATING_MAX + 1)
    elif current.kind == StepKind.ATTENTION:
        texts = participant_texts(domain)
        ctx["question"], ctx["choices"] = texts.attention_question, texts.attention_choices
    elif current.kind == StepKind.DEMOGRAPHICS:
        ctx["genders"] = [(key, str(label)) for key, label in forms.GENDER_CHOICES]
        ctx["age_min"], ctx["age_max"] = forms.AGE_MIN, forms.AGE_MAX
    elif current.kind == StepKind.DONE:
        ctx.update(completion_target(participant))
        if participant.bonus is not None and bonuses.offers_bonus(participant.study) and not participant.excluded:
            ctx["bonus"] = bonuses.participant_label(participant.study, participant.bonus)
    return ctx


def show_endings(scene: dict, rules: dict) -> list[str]:
    """What ends the way on a show page, in the participant's language, one sentence each: what "finished"
    means there (a square marked G, the object put down on D, the "Stop here" button)."""
    out = []
    if scene["world"].get("goals"):
        out.append(gettext("it reaches a square marked G"))
    if rules.get("deliver"):
        out.append(gettext("it puts the {object} down on the square marked D").format(
            object=rules["object"] or gettext("object")))
    if rules.get("exit"):
        out.append(gettext("you press “Stop here”: the robot stays where it is"))
    return out


def caption_of(domain, payload: dict) -> tuple[str, str] | None:
    """The domain's caption above a canvas (what to look for, and its value there), in the participant's
    language: both parts are English texts the domain marks for the catalog."""
    caption = domain.caption(payload)
    return tuple(gettext(part) for part in caption) if caption else caption


def planned_steps(participant: Participant, steps: list[flow.Step]) -> int:
    """How many steps the participant's flow has: a closed loop that is not done yet decides its steps as
    it goes, so the progress bar counts the most it may still show (examples, checks and feedback)."""
    loop = participant.condition.closed_loop
    if not loop or steps[-1].kind == StepKind.DONE:
        return len(steps)
    s = loop["settings"]
    n_loop = s["max_examples"] + closedloop.max_checks(loop) * (2 if s["feedback"] else 1)
    before = 3 if participant.study.comprehension_check else 2  # consent, instructions (and the comprehension check)
    return before + n_loop + len(participant.study.test_set) + 3  # ...; attention, demographics, done


def repeated_example(training: list[dict], item: int) -> int | None:
    """The number (1-based) of the last earlier example showing the same environment as example `item`,
    or None.  A sequence may repeat an environment on purpose (prob-reward shows two environments ten
    times); without a word on the page a repeat looks like a glitch.  Only the number reaches the page."""
    env_id = training[item].get("env_id")
    earlier = [i for i in range(item) if env_id is not None and training[i].get("env_id") == env_id]
    return earlier[-1] + 1 if earlier else None


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


def completion_target(participant: Participant) -> dict:
    """Where a finished or ended participant is sent back to, with their code (only once every answer is
    stored, or their outcome set): Prolific's completion address with the code, or MTurk's submit form."""
    study, code = participant.study, participant.completion_code
    if (participant.completed_at is None and not participant.outcome) or not code:
        return {}
    if participant.platform == Participant.PROLIFIC:
        return {"redirect_url": study.prolific_completion_url.format(code=code)}
    if participant.platform == Participant.MTURK and participant.platform_session_id:
        try:  # checked again: a row stored before the allowlist may hold anything
            site = mturk_submit_base(participant.turk_submit_to)
        except ValueError:
            site = ""
        base = site + "/mturk/externalSubmit" if site else study.mturk_submit_url
        return {"mturk_form": {"action": base, "assignmentId": participant.platform_session_id,
                               "completion_code": code}}
    return {}


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
    """The refusal page if the participant's device may not take part (studyapp.devices); None otherwise.
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

