"""The participant's path through a study and the validation of each answer.

Steps, in order: consent, instructions, one per training environment, one
per test, attention check, demographics, then ``done``.  A participant's
``position`` is the index of the step they are on; an answer is accepted only
for that step, is validated before anything is written, and is stored
exactly once (a repeated identical POST is a no-op that succeeds).
"""
from __future__ import annotations

from dataclasses import dataclass

from django.db import IntegrityError, transaction
from django.utils import timezone

from .models import Answer, Participant

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


@dataclass(frozen=True)
class Step:
    index: int
    kind: str  # consent, instructions, training, test, attention, demographics, done
    item: int | None = None


class AnswerError(Exception):
    """An answer that is rejected; nothing was written."""

    def __init__(self, message: str, status: int = 400):
        super().__init__(message)
        self.message, self.status = message, status


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
def _one(post, name: str) -> str:
    values = post.getlist(name)
    if len(values) != 1 or not values[0].strip():
        raise AnswerError(f"'{name}' is required (exactly one value)")
    return values[0].strip()


def _int(post, name: str, low: int, high: int) -> int:
    raw = _one(post, name)
    try:
        value = int(raw)
    except ValueError:
        raise AnswerError(f"'{name}' must be a whole number, got {raw!r}") from None
    if not low <= value <= high:
        raise AnswerError(f"'{name}' must lie between {low} and {high}, got {value}")
    return value


def clean_answer(participant: Participant, step: Step, post) -> dict:
    if step.kind == "consent":
        if _one(post, "consent") != "yes":
            raise AnswerError("consent must be 'yes' to continue")
        return {"consent": True}
    if step.kind == "instructions":
        _one(post, "ack")
        return {"ack": True}
    if step.kind == "training":
        if _one(post, "played") != "1":
            raise AnswerError("the animation must be played before continuing")
        return {"env_id": participant.condition.training[step.item]["env_id"]}
    if step.kind == "test":
        return clean_test(participant, step.item, post)
    if step.kind == "attention":
        goals = post.getlist("goals")
        known = {key for key, _ in ATTENTION_CHOICES}
        if not goals:
            raise AnswerError("choose the goals you saw")
        unknown = set(goals) - known
        if unknown:
            raise AnswerError(f"unknown goal(s): {', '.join(sorted(unknown))}")
        return {"goals": sorted(set(goals)), "passed": set(goals) == ATTENTION_CORRECT}
    if step.kind == "demographics":
        gender = _one(post, "gender")
        if gender not in {key for key, _ in GENDER_CHOICES}:
            raise AnswerError(f"unknown gender option {gender!r}")
        data = {"age": _int(post, "age", AGE_MIN, AGE_MAX), "gender": gender}
        if gender == "other":
            data["gender_text"] = post.get("gender_text", "").strip()[:100]
        return data
    raise AnswerError("this step takes no answer", status=409)


def clean_test(participant: Participant, j: int, post) -> dict:
    options = participant.study.test_set[j]["options"]
    ids = range(len(options))
    raw = _one(post, "choice")
    if raw not in {str(k) for k in ids}:
        raise AnswerError(f"unknown option {raw!r}: options are 0-{len(options) - 1}")
    choice = int(raw)
    ratings = [_int(post, f"rating_{k}", RATING_MIN, RATING_MAX) for k in ids]
    extra = [key for key in post if key.startswith("rating_") and key not in {f"rating_{k}" for k in ids}]
    if extra:
        raise AnswerError(f"unknown option(s) rated: {', '.join(sorted(extra))}")
    played = set(post.getlist("played"))
    if played != {str(k) for k in ids}:
        raise AnswerError("every option must be played at least once")
    return {
        "env_id": participant.study.test_set[j]["env_id"],
        "choice": choice,
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
        raise AnswerError(f"this study has no step {step_index}", status=404)
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
            raise AnswerError("this question was already answered; the stored answer cannot be changed", status=409)
        if step_index != locked.position:
            raise AnswerError(f"you are on step {locked.position}, not step {step_index}", status=409)
        answer = Answer(participant=locked, step=step_index, kind=step.kind, item=step.item, data=data)
        if step.kind == "test":
            answer.chosen_option = data["choice"]
            answer.correct, answer.confidence_score = score_test(locked, step.item, data)
        try:
            with transaction.atomic():
                answer.save()
        except IntegrityError:
            raise AnswerError("this question was already answered", status=409) from None
        now = timezone.now()
        locked.position = step_index + 1
        locked.last_seen_at = now
        if step.kind == "attention":
            locked.excluded = not data["passed"]
        if steps[locked.position].kind == "done":
            locked.completed_at = now
            locked.completion_code = locked.study.completion_code or locked.completion_code or _code()
        locked.save()
        return locked


def _code() -> str:
    from .models import new_code

    return new_code()
