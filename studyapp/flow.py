"""The participant's path through a study and the recording of each answer (validated by studyapp.forms).

Steps, in order: consent, instructions, the comprehension check (if the study asks it), one per
training environment, one per test (choosing among options, or showing the way: Study.test_kind),
attention check, demographics, then ``done``.  A participant's
``position`` is the index of the step they are on; an answer is accepted only
for that step, is validated before anything is written, and is stored
exactly once (a repeated identical POST is a no-op that succeeds).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

from django.db import IntegrityError, transaction
from django.utils import timezone
from django.utils.translation import gettext, gettext_noop

from . import bonuses, closedloop, comprehension, outcomes, status
from .forms import STEP_FORMS, ShowForm, TestForm
from .models import Answer, ComprehensionAttempt, LoopStep, Participant, StepKind, Study
from .trajectories import study_domain

logger = logging.getLogger(__name__)

LETTERS = "ABCDEFGH"  # options as the participant sees them


@dataclass(frozen=True)
class Step:
    index: int
    kind: StepKind
    item: int | None = None


class AnswerError(Exception):
    """An answer that is rejected; nothing was written.

    `moved`: the page was out of date (the step was answered in another tab, or the participant
    is elsewhere in the study); the participant is sent to where they are, with `MOVED_ON`."""

    def __init__(self, message: str, status: int = 400, moved: bool = False):
        super().__init__(message)
        self.message, self.status, self.moved = message, status, moved


# English, as tests and pages compare them; shown through gettext, in the participant's language
ENDED = gettext_noop("This study has ended for you, so this answer was not saved.")

MOVED_ON = gettext_noop("That page was out of date (perhaps answered in another tab or window), "
                        "so your answer there was not saved again. You are now on your current step.")


def steps_for(participant: Participant) -> list[Step]:
    """The participant's steps.  A closed-loop condition's teaching steps are decided one at a time
    (studyapp.closedloop): its list ends at the step the participant stands on until the loop is done."""
    kinds = [(StepKind.CONSENT, None), (StepKind.INSTRUCTIONS, None)]
    if participant.study.comprehension_check:
        kinds.append((StepKind.COMPREHENSION, None))
    if closedloop.is_closed_loop(participant.condition):
        loop = closedloop.loop_steps(participant, first_step=len(kinds))
        kinds += [(closedloop.STEP_KINDS[s.kind], s.index) for s in loop if s.kind != LoopStep.DONE]
        if not loop or loop[-1].kind != LoopStep.DONE:
            return [Step(i, kind, item) for i, (kind, item) in enumerate(kinds)]
    else:
        kinds += [(StepKind.TRAINING, i) for i in range(len(participant.condition.training))]
    kinds += [(StepKind.TEST, j) for j in range(len(participant.study.test_set))]
    kinds += [(StepKind.ATTENTION, None), (StepKind.DEMOGRAPHICS, None), (StepKind.DONE, None)]
    return [Step(i, kind, item) for i, (kind, item) in enumerate(kinds)]


def current_step(participant: Participant) -> Step:
    steps = steps_for(participant)
    return steps[min(participant.position, len(steps) - 1)]


# --- validation: POST data -> the JSON stored in Answer.data (studyapp.forms) ---------
def clean_answer(participant: Participant, step: Step, post) -> dict:
    form_class = STEP_FORMS.get(step.kind)
    if form_class is None:
        raise AnswerError(gettext("This page takes no answer."), status=409)
    if step.kind in (StepKind.TEST, StepKind.CHECK) and participant.study.test_kind == Study.SHOW:
        form = ShowForm(post, participant, step, question_of(participant, step.kind, step.item))
    elif form_class is TestForm:
        form = TestForm(post, participant, step, shown=option_letters(participant, step.item, step.kind),
                        env_id=question_of(participant, step.kind, step.item)["env_id"])
    else:
        form = form_class(post, participant, step)
    if not form.is_valid():
        raise AnswerError(form.first_error())
    return form.answer()


def option_letters(participant: Participant, j: int, kind: StepKind = StepKind.TEST) -> list[tuple[str, int]]:
    """(letter, option index) of test j's (or, for a CHECK, loop step j's) options as this participant
    sees them, top to bottom.

    The page names options only by these letters, so nothing in it tells theta*'s option
    apart (the option indices, where theta*'s may sit first, stay on the server)."""
    order = (participant.loop_steps.get(index=j).option_order if kind == StepKind.CHECK
             else participant.option_orders[j])
    return [(LETTERS[pos], k) for pos, k in enumerate(order)]


def question_of(participant: Participant, kind: StepKind, j: int) -> dict:
    """The stored test (or check question, for a CHECK step j) the participant answers."""
    if kind == StepKind.CHECK:
        step = participant.loop_steps.get(index=j)
        return participant.condition.closed_loop["checks"][step.question]
    return participant.study.test_set[j]


def score_test(participant: Participant, j: int, data: dict, kind: StepKind = StepKind.TEST) -> tuple[bool, int]:
    """(correct, confidence score): the chosen option's rating, negated if it is not theta*'s."""
    option = question_of(participant, kind, j)["options"][data["choice"]]
    rating = data["ratings"][data["choice"]]
    correct = bool(option["is_theta_star"])
    return correct, rating if correct else -rating


def score_show(participant: Participant, j: int, data: dict,
               kind: StepKind = StepKind.TEST) -> tuple[bool, float, int | None]:
    """(optimal, regret, way) of the way shown in show test j (or loop step j's check): replayed under θ*
    (Domain.score_shown); `way` is, for a check, which of its ways it is (closedloop.way_index), else None."""
    question = question_of(participant, kind, j)
    score = study_domain(participant.study).score_shown(question["env_id"], data["moves"])
    way = closedloop.way_index(question, score["rows"]) if kind == StepKind.CHECK else None
    return bool(score["optimal"]), float(score["regret"]), way


# --- recording ---------------------------------------------------------------
def _elsewhere(participant: Participant, step_index: int) -> str:
    return gettext("You are on step {current}, not step {asked}.").format(current=participant.position + 1,
                                                                           asked=step_index + 1)


def record(participant: Participant, step_index: int, post) -> Participant:
    """Validate and store the answer to step `step_index`; returns the updated participant.

    Raises AnswerError (nothing written) for a bad answer, a step the
    participant is not on, or a stored step answered differently.  Repeating
    the stored answer succeeds without writing.
    """
    steps = steps_for(participant)
    if not 0 <= step_index < len(steps):
        raise AnswerError(gettext("This study has no such step; please use the link you were given."), status=404)
    step = steps[step_index]
    # Timed out before the lock: the outcome's own conditional update must not roll back with a refusal.
    if outcomes.check_time(participant):
        raise AnswerError(gettext(ENDED), status=409, moved=True)
    data = clean_answer(participant, step, post)
    with transaction.atomic():
        # Lock only the participant's row: a FOR UPDATE joined with the study locks the study row too,
        # which serialised every answer in the study behind one lock (and behind every arrival's
        # assignment): p50 436 ms at ~50 requests/s (tests/load).  The caller's study and condition are
        # reused: reading them again decoded the study's JSON (test set, pilot) once more per answer.
        locked = Participant.objects.select_for_update(of=("self",)).get(pk=participant.pk)
        locked.study, locked.condition = participant.study, participant.condition
        if locked.outcome:  # returned, timed out or screened out since the page was drawn
            raise AnswerError(gettext(ENDED), status=409, moved=True)
        if step.kind == StepKind.COMPREHENSION:
            return record_attempt(locked, step_index, data)
        # Only a step before the participant's position can hold an answer (the position moves on with each
        # answer stored, under this lock), so an answer to the current step needs no lookup.
        stored = (Answer.objects.filter(participant=locked, step=step_index).first()
                  if step_index < locked.position else None)
        if stored is not None:
            if stored.data == data:
                return locked  # idempotent repeat
            raise AnswerError(gettext("This question was already answered; an answer cannot be changed."), status=409,
                              moved=True)
        if step_index != locked.position:
            raise AnswerError(_elsewhere(locked, step_index), status=409,
                              moved=True)
        answer = Answer(participant=locked, step=step_index, kind=step.kind, item=step.item, data=data)
        if step.kind in (StepKind.TEST, StepKind.CHECK) and locked.study.test_kind == Study.SHOW:
            answer.correct, answer.regret, answer.chosen_option = score_show(locked, step.item, data, step.kind)
        elif step.kind in (StepKind.TEST, StepKind.CHECK):
            answer.chosen_option = data["choice"]
            answer.correct, answer.confidence_score = score_test(locked, step.item, data, step.kind)
        try:
            with transaction.atomic():
                answer.save()
        except IntegrityError:
            raise AnswerError(gettext("This question was already answered."), status=409, moved=True) from None
        now = timezone.now()
        locked.position = step_index + 1
        locked.last_seen_at = now
        if step.kind == StepKind.ATTENTION:
            locked.excluded = not data["passed"]
        # a closed-loop participant's next teaching step is decided when they reach it (steps_for)
        finished = locked.position < len(steps) and steps[locked.position].kind == StepKind.DONE
        if finished:
            locked.completed_at = now
            # a code pays: never for a participant who answered no test question (a study whose build gave it
            # none takes no one, Study.running_problems; this holds whatever a study's tests became since)
            if Answer.objects.filter(participant=locked, kind=StepKind.TEST).exists():
                locked.completion_code = outcomes.code_for(locked, status.EXCLUDED if locked.excluded
                                                           else status.COMPLETE)
                locked.bonus = bonuses.compute(locked)  # once, from the answers stored under this lock
            else:
                locked.completion_code, locked.bonus = "", None
                logger.warning("participant %s finished study %r without a test answer: no code, no bonus",
                               locked.pk, locked.study.slug)
        # Only what an answer changes: writing every column re-encoded the participant's JSON (option orders,
        # session ids) at each answer.  The row was read under this lock, so the other columns are as stored.
        locked.save(update_fields=["position", "last_seen_at", "excluded", "completed_at", "completion_code",
                                   "bonus"])
        if finished:
            logger.info("participant %s completed study %r (condition %r%s)", locked.pk, locked.study.slug,
                        locked.condition.name, ", excluded by the attention check" if locked.excluded else "")
        return locked


def record_attempt(locked: Participant, step_index: int, data: dict) -> Participant:
    """Store one attempt at the comprehension check (the caller holds the participant's row lock): passed,
    the step's Answer is written and the participant moves on; failed too often, they are screened out.

    ``data["attempt"]`` is the number the page was drawn for: an attempt stored under it already is a
    replay (a double click, a retried post), a no-op when its answers are the same, so nothing is counted
    twice; any other number is a page out of date."""
    number, answers = data["attempt"], data["answers"]
    stored = locked.comprehension_attempts.filter(number=number).first()
    if stored is not None:
        if stored.answers == answers:
            return locked  # idempotent repeat
        raise AnswerError(gettext("These answers were already checked; please answer on the current page."), status=409,
                          moved=True)
    if step_index != locked.position:
        raise AnswerError(_elsewhere(locked, step_index), status=409, moved=True)
    current = locked.comprehension_attempts.count() + 1
    if number != current:  # the right step, but a page drawn for another attempt (an old tab, a tampered post)
        raise AnswerError(gettext("This page is out of date: it sent attempt {sent} at the questions of step {step}, "
                                  "and you are on attempt {current}. Please answer on the current page.").format(
                                      sent=number, step=step_index + 1, current=current), status=409, moved=True)
    missed = comprehension.missed(comprehension.questions_of(locked.study), answers)
    now = timezone.now()
    try:
        with transaction.atomic():
            ComprehensionAttempt.objects.create(participant=locked, number=number, answers=answers, missed=missed,
                                                passed=not missed, created_at=now)
            if not missed:
                Answer.objects.create(participant=locked, step=step_index, kind=StepKind.COMPREHENSION,
                                      data={"attempts": number, "answers": answers}, correct=True, created_at=now)
    except IntegrityError:
        raise AnswerError(gettext("These answers were already checked."), status=409, moved=True) from None
    locked.last_seen_at = now
    if not missed:
        locked.position = step_index + 1
    locked.save(update_fields=["position", "last_seen_at"])
    if missed and number >= locked.study.comprehension_attempts:
        outcomes.end(locked, status.SCREENED_OUT, now)
    return locked


def decline(participant: Participant, step_index: int) -> bool:
    """"I do not agree" on the consent page: delete the participant (their platform ids, condition and
    display orders) so that nothing about them is kept and their condition's place is free at once.

    Only while they stand on consent with nothing stored; returns False (nothing deleted) otherwise,
    e.g. when another tab has already agreed."""
    with transaction.atomic():
        locked = Participant.objects.select_for_update().filter(pk=participant.pk).first()
        if locked is None:
            return True  # declined already (double click): nothing is left to delete
        steps = steps_for(locked)
        if not (step_index == locked.position and steps[step_index].kind == StepKind.CONSENT
                and not locked.answers.exists()):
            return False
        locked.delete()
    logger.info("a participant of study %r declined consent; their row was deleted", participant.study.slug)
    return True

