"""The participant's path through a study and the validation of each answer.

Steps, in order: consent, instructions, one per training environment, one
per test, attention check, demographics, then ``done``.  A participant's
``position`` is the index of the step they are on; an answer is accepted only
for that step, is validated before anything is written, and is stored
exactly once (a repeated identical POST is a no-op that succeeds).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

from django.db import IntegrityError, transaction
from django.utils import timezone

from .models import Answer, Participant, new_code

logger = logging.getLogger(__name__)

ATTENTION_CHOICES = [
    ("merge", "Merge into the right lane"),
    ("forward", "Drive forward"),
    ("park", "Park on the shoulder"),
    ("left", "Turn into the left lane and stop"),
    ("exit", "Take the next exit"),
    ("overtake", "Overtake every car it meets"),
]
ATTENTION_CORRECT = frozenset({"merge", "forward"})
GENDER_CHOICES = [
    ("female", "Female"),
    ("male", "Male"),
    ("non-binary", "Non-binary"),
    ("other", "Prefer to self-describe"),
    ("undisclosed", "Prefer not to say"),
]
AGE_MIN, AGE_MAX = 18, 120
RATING_MIN, RATING_MAX = 1, 7
LETTERS = "ABCDEFGH"  # options as the participant sees them


@dataclass(frozen=True)
class Step:
    index: int
    kind: str  # consent, instructions, training, test, attention, demographics, done
    item: int | None = None


class AnswerError(Exception):
    """An answer that is rejected; nothing was written.

    `moved`: the page was out of date (the step was answered in another tab, or the participant
    is elsewhere in the study); the participant is sent to where they are, with `MOVED_ON`."""

    def __init__(self, message: str, status: int = 400, moved: bool = False):
        super().__init__(message)
        self.message, self.status, self.moved = message, status, moved


MOVED_ON = ("That page was out of date (perhaps answered in another tab or window), "
            "so your answer there was not saved again. You are now on your current step.")


def steps_for(participant: Participant) -> list[Step]:
    kinds = [("consent", None), ("instructions", None)]
    kinds += [("training", i) for i in range(len(participant.condition.training))]
    kinds += [("test", j) for j in range(len(participant.study.test_set))]
    kinds += [("attention", None), ("demographics", None), ("done", None)]
    return [Step(i, kind, item) for i, (kind, item) in enumerate(kinds)]


def current_step(participant: Participant) -> Step:
    steps = steps_for(participant)
    return steps[min(participant.position, len(steps) - 1)]


# --- validation: POST data -> the JSON stored in Answer.data -----------------
# Every message is in the participant's words: the page calls things "Option B", "your age".
def _one(post, name: str, missing: str) -> str:
    values = post.getlist(name)
    if len(values) != 1 or not values[0].strip():
        raise AnswerError(missing)
    return values[0].strip()


def _int(post, name: str, low: int, high: int, missing: str, what: str) -> int:
    raw = _one(post, name, missing)
    try:
        value = int(raw)
    except ValueError:
        raise AnswerError(f"{what} must be a whole number from {low} to {high}.") from None
    if not low <= value <= high:
        raise AnswerError(f"{what} must be a whole number from {low} to {high}.")
    return value


def clean_answer(participant: Participant, step: Step, post) -> dict:
    if step.kind == "consent":
        if _one(post, "consent", "Please say whether you agree to take part.") != "yes":
            raise AnswerError("You can only continue if you agree to take part.")
        return {"consent": True}
    if step.kind == "instructions":
        _one(post, "ack", "Please confirm that you have read the instructions.")
        return {"ack": True}
    if step.kind == "training":
        if post.get("played") != "1":
            raise AnswerError("Please watch the whole animation before you continue.")
        return {"env_id": participant.condition.training[step.item]["env_id"]}
    if step.kind == "test":
        return clean_test(participant, step.item, post)
    if step.kind == "attention":
        goals = post.getlist("goals")
        known = {key for key, _ in ATTENTION_CHOICES}
        if not goals:
            raise AnswerError("Please tick the goals you saw.")
        if set(goals) - known:
            raise AnswerError("Please tick only goals from the list.")
        return {"goals": sorted(set(goals)), "passed": set(goals) == ATTENTION_CORRECT}
    if step.kind == "demographics":
        gender = _one(post, "gender", "Please choose an answer for gender (or 'Prefer not to say').")
        if gender not in {key for key, _ in GENDER_CHOICES}:
            raise AnswerError("Please choose an answer for gender from the list.")
        data = {"age": _int(post, "age", AGE_MIN, AGE_MAX, "Please enter your age.", "Your age"), "gender": gender}
        if gender == "other":
            data["gender_text"] = post.get("gender_text", "").strip()[:100]
        return data
    raise AnswerError("This page takes no answer.", status=409)


def option_letters(participant: Participant, j: int) -> list[tuple[str, int]]:
    """(letter, option index) of test j's options as this participant sees them, top to bottom.

    The page names options only by these letters, so nothing in it tells theta*'s option
    apart (the option indices, where theta*'s may sit first, stay on the server)."""
    return [(LETTERS[pos], k) for pos, k in enumerate(participant.option_orders[j])]


def clean_test(participant: Participant, j: int, post) -> dict:
    shown = option_letters(participant, j)
    letters = [letter for letter, _ in shown]
    listed = ", ".join(letters)
    played = set(post.getlist("played"))
    if not played <= set(letters):
        raise AnswerError(f"This question has options {listed} only; please reload the page.")
    unplayed = [letter for letter in letters if letter not in played]
    if unplayed:
        raise AnswerError(f"Please play option {', '.join(unplayed)} before you continue.")
    chosen = _one(post, "choice", "Please choose the option that matches the car's driving style.")
    if chosen not in letters:
        raise AnswerError(f"This question has options {listed} only; please choose one of them.")
    extra = sorted(key for key in post if key.startswith("rating_") and key[len("rating_"):] not in letters)
    if extra:
        raise AnswerError(f"This question has options {listed} only; please reload the page.")
    ratings = [0] * len(shown)
    for letter, k in shown:
        ratings[k] = _int(post, f"rating_{letter}", RATING_MIN, RATING_MAX,
                          f"Please rate how well option {letter} matches (1 = not at all, 7 = exactly).",
                          f"The rating of option {letter}")
    return {
        "env_id": participant.study.test_set[j]["env_id"],
        "choice": dict(shown)[chosen],
        "ratings": ratings,
        "order": participant.option_orders[j],
    }


def score_test(participant: Participant, j: int, data: dict) -> tuple[bool, int]:
    """(correct, confidence score): the chosen option's rating, negated if it is not theta*'s."""
    option = participant.study.test_set[j]["options"][data["choice"]]
    rating = data["ratings"][data["choice"]]
    correct = bool(option["is_theta_star"])
    return correct, rating if correct else -rating


# --- recording ---------------------------------------------------------------
def record(participant: Participant, step_index: int, post) -> Participant:
    """Validate and store the answer to step `step_index`; returns the updated participant.

    Raises AnswerError (nothing written) for a bad answer, a step the
    participant is not on, or a stored step answered differently.  Repeating
    the stored answer succeeds without writing.
    """
    steps = steps_for(participant)
    if not 0 <= step_index < len(steps):
        raise AnswerError("This study has no such step; please use the link you were given.", status=404)
    step = steps[step_index]
    data = clean_answer(participant, step, post)
    with transaction.atomic():
        # of=("self",): lock only the participant's row.  A bare FOR UPDATE with select_related
        # also locks the joined study row, which serialised every answer in the study behind one
        # lock (and behind every arrival's assignment): p50 436 ms at ~50 requests/s (tests/load).
        locked = (Participant.objects.select_for_update(of=("self",)).select_related("study", "condition")
                  .get(pk=participant.pk))
        stored = Answer.objects.filter(participant=locked, step=step_index).first()
        if stored is not None:
            if stored.data == data:
                return locked  # idempotent repeat
            raise AnswerError("This question was already answered; an answer cannot be changed.", status=409,
                              moved=True)
        if step_index != locked.position:
            raise AnswerError(f"You are on step {locked.position + 1}, not step {step_index + 1}.", status=409,
                              moved=True)
        answer = Answer(participant=locked, step=step_index, kind=step.kind, item=step.item, data=data)
        if step.kind == "test":
            answer.chosen_option = data["choice"]
            answer.correct, answer.confidence_score = score_test(locked, step.item, data)
        try:
            with transaction.atomic():
                answer.save()
        except IntegrityError:
            raise AnswerError("This question was already answered.", status=409, moved=True) from None
        now = timezone.now()
        locked.position = step_index + 1
        locked.last_seen_at = now
        if step.kind == "attention":
            locked.excluded = not data["passed"]
        finished = steps[locked.position].kind == "done"
        if finished:
            locked.completed_at = now
            locked.completion_code = locked.study.completion_code or locked.completion_code or _code()
        locked.save()
        if finished:
            logger.info("participant %s completed study %r (condition %r%s)", locked.pk, locked.study.slug,
                        locked.condition.name, ", excluded by the attention check" if locked.excluded else "")
        return locked


def _code() -> str:
    return new_code()
