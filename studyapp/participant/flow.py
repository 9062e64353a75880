"""The participant's path through a study and the recording of each answer (checked by its page's form).

Steps, in the order of studyapp.participant.pages' PAGE_SEQUENCE: consent, instructions, the comprehension check (if
the study asks it), one per training environment, one per test (choosing among options, or showing the
way: Study.test_kind), attention check, demographics, then ``done``.  A participant's
``position`` is the index of the step they are on; an answer is accepted only
for that step, is validated before anything is written, and is stored
exactly once (a repeated identical POST is a no-op that succeeds).
"""
from __future__ import annotations

import logging

from django.db import IntegrityError, transaction
from django.utils import timezone
from django.utils.translation import gettext, gettext_noop

from .. import status
from ..models import Answer, LoopStep, Participant, StepKind
from . import bonuses, closedloop, outcomes
from .pages import PAGE_SEQUENCE, PAGES, AnswerError, Step, option_letters, page_for, question_of
from .pages.base import elsewhere, replayed

logger = logging.getLogger(__name__)

__all__ = ["AnswerError", "Step", "current_step", "decline", "option_letters", "planned_steps", "question_of",
           "record", "steps_for"]

# English, as tests and pages compare them; shown through gettext, in the participant's language
ENDED = gettext_noop("This study has ended for you, so this answer was not saved.")

MOVED_ON = gettext_noop("That page was out of date (perhaps answered in another tab or window), "
                        "so your answer there was not saved again. You are now on your current step.")


def steps_for(participant: Participant) -> list[Step]:
    """The participant's steps: each kind of PAGE_SEQUENCE with its items.  A closed-loop condition's
    teaching steps are decided one at a time (studyapp.participant.closedloop): its list ends at the step the
    participant stands on until the loop is done."""
    kinds = []
    for kind in PAGE_SEQUENCE:
        if kind == StepKind.TRAINING and closedloop.is_closed_loop(participant.condition):
            loop = closedloop.loop_steps(participant, first_step=len(kinds))
            kinds += [(closedloop.STEP_KINDS[s.kind], s.index) for s in loop if s.kind != LoopStep.DONE]
            if not loop or loop[-1].kind != LoopStep.DONE:
                break
        else:
            kinds += [(kind, item) for item in PAGES[kind].items(participant)]
    return [Step(i, kind, item) for i, (kind, item) in enumerate(kinds)]


def current_step(participant: Participant) -> Step:
    steps = steps_for(participant)
    return steps[min(participant.position, len(steps) - 1)]


def planned_steps(participant: Participant) -> int:
    """How many steps the participant's flow has: a closed loop that is not done yet decides its steps as
    it goes, so the progress bar counts the most it may still show (examples, checks and feedback)."""
    steps = steps_for(participant)
    loop = participant.condition.closed_loop
    if not loop or steps[-1].kind == StepKind.DONE:
        return len(steps)
    s = loop["settings"]
    n_loop = s["max_examples"] + closedloop.max_checks(loop) * (2 if s["feedback"] else 1)
    return n_loop + sum(len(PAGES[kind].items(participant)) for kind in PAGE_SEQUENCE if kind != StepKind.TRAINING)


def clean_answer(participant: Participant, step: Step, post) -> dict:
    """POST data -> the JSON stored in Answer.data, checked by the step's form; AnswerError otherwise."""
    form = page_for(participant.study, step.kind).bind(participant, step, post)
    if not form.is_valid():
        raise AnswerError(form.first_error())
    return form.answer()


# --- recording ---------------------------------------------------------------
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
    page = page_for(participant.study, step.kind)
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
        own = page.store(locked, step_index, step, data)  # a page that stores its answer its own way
        if own is not None:
            return own
        # Only a step before the participant's position can hold an answer (the position moves on with each
        # answer stored, under this lock), so an answer to the current step needs no lookup.
        stored = (Answer.objects.filter(participant=locked, step=step_index).values_list("data", flat=True).first()
                  if step_index < locked.position else None)
        if replayed(stored, data, gettext("This question was already answered; an answer cannot be changed.")):
            return locked
        if step_index != locked.position:
            raise AnswerError(elsewhere(locked, step_index), status=409, moved=True)
        answer = Answer(participant=locked, step=step_index, kind=step.kind, item=step.item, data=data)
        page.score(answer, locked, step, data)
        try:
            with transaction.atomic():
                answer.save()
        except IntegrityError:
            raise AnswerError(gettext("This question was already answered."), status=409, moved=True) from None
        now = timezone.now()
        locked.position = step_index + 1
        locked.last_seen_at = now
        page.stored(locked, data)
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

