"""The pages before the robot's examples: consent, the instructions and the comprehension check on them."""
from __future__ import annotations

from django.db import IntegrityError, transaction
from django.utils import timezone
from django.utils.translation import gettext
from django.utils.translation import gettext_lazy as _

from ... import status
from ...models import Answer, ComprehensionAttempt, StepKind
from ...scenes import instructions
from .. import bonuses, comprehension, devices, outcomes
from ..forms import ConsentForm, InstructionsForm
from .base import AnswerError, Page, add, elsewhere, replayed

# Closed-loop conditions (studyapp.participant.closedloop) add to the domain's instructions.
CHECK_INSTRUCTIONS = _("Between the examples you will sometimes answer a check question, just like the questions "
                       "at the end. Your answers decide which example you see next; they do not count towards "
                       "your score.")
# appended to CHECK_INSTRUCTIONS after a space (kept out of the catalog's text, so no translator loses it)
FEEDBACK_INSTRUCTIONS = _("After each check question you will see the right answer: what really happens there.")


class ConsentPage(Page):
    """What taking part means, what it pays and which devices may take part; "I agree" or not (the view
    deletes one who does not)."""

    kind, form = StepKind.CONSENT, ConsentForm

    def context(self, participant, step, ctx):
        study, out = participant.study, {}
        out["bonus_rule"] = bonuses.rule_text(study)  # what they are paid for, before they agree
        if study.payment_amount is not None:  # money written one way on every page
            out["payment_amount"] = bonuses.participant_label(study, study.payment_amount)
        if study.has_device_rules:
            out["device_rules"] = devices.rules(study)
        return out

    def simulate(self, sim, participant, step):
        return {"consent": "yes"}


def instructions_context(participant, ctx: dict) -> dict:
    """The instructions' paragraphs, with a closed loop's word on its check questions."""
    paragraphs = instructions(participant.study, ctx["total_training"], ctx["total_tests"])
    loop = participant.condition.closed_loop
    if loop and loop["settings"]["check_every"]:
        paragraphs.append(str(CHECK_INSTRUCTIONS) + (" " + str(FEEDBACK_INSTRUCTIONS)
                                                     if loop["settings"]["feedback"] else ""))
    return {"instructions": paragraphs}


class InstructionsPage(Page):
    kind, form, draws_robot = StepKind.INSTRUCTIONS, InstructionsForm, True

    def context(self, participant, step, ctx):
        return instructions_context(participant, ctx)

    def simulate(self, sim, participant, step):
        return {"ack": "1"}


class ComprehensionPage(Page):
    """Questions on the instructions (Study.comprehension_check): each attempt stored, the instructions
    shown again after a failed one, and a participant who fails too often screened out."""

    kind, form, draws_robot = StepKind.COMPREHENSION, comprehension.ComprehensionForm, True

    def items(self, participant):
        return (None,) if participant.study.comprehension_check else ()

    def context(self, participant, step, ctx):
        return {**comprehension.page_context(participant), **instructions_context(participant, ctx)}

    def store(self, locked, step_index, step, data):
        return record_attempt(locked, step_index, data)

    def simulate(self, sim, participant, step):
        """Every question's right choices, at the next attempt."""
        body = {"attempt": participant.comprehension_attempts.count() + 1}
        body.update({f"q{i}": list(q["right"]) for i, q in enumerate(comprehension.questions_of(participant.study))})
        return body


def record_attempt(locked, step_index: int, data: dict):
    """Store one attempt at the comprehension check (the caller holds the participant's row lock): passed,
    the step's Answer is written and the participant moves on; failed too often, they are screened out.

    ``data["attempt"]`` is the number the page was drawn for: an attempt stored under it already is a
    replay (a double click, a retried post), a no-op when its answers are the same, so nothing is counted
    twice; any other number is a page out of date."""
    number, answers = data["attempt"], data["answers"]
    stored = locked.comprehension_attempts.filter(number=number).values_list("answers", flat=True).first()
    if replayed(stored, answers, gettext("These answers were already checked; please answer on the current page.")):
        return locked
    if step_index != locked.position:
        raise AnswerError(elsewhere(locked, step_index), status=409, moved=True)
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


CONSENT, INSTRUCTIONS, COMPREHENSION = add(ConsentPage()), add(InstructionsPage()), add(ComprehensionPage())
