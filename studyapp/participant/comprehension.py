"""The comprehension check a study may ask after its instructions (Study.comprehension_check).

A study's questions are its own (Study.comprehension_questions) or, when it gives none, its domain's
(ParticipantTexts.comprehension), each stored and served as ``{"question", "choices", "right"}``.  The
researcher writes them in the designer as plain text (:func:`parse_text`, :func:`format_text`)::

    What will you watch first?
    - A written test
    * Short examples of the robot
    - Nothing

one question per block (blocks separated by a blank line): its first line the question, then one line
per choice, ``* `` for a right one and ``- `` for a wrong one.

The page names the choices only by their position (``q<i>`` = ``k``), so its source says nothing about
which are right: they stay on the server.  Every attempt is stored (models.ComprehensionAttempt: flow.record
writes it); the participant who passes goes on, one who fails reads the instructions again with the
questions they missed named, and one who fails ``Study.comprehension_attempts`` times is screened out.
"""
from __future__ import annotations

from django import forms
from django.utils.translation import gettext
from django.utils.translation import gettext_lazy as _

from ..guards.inputs import WholeNumberField
from ..i18n import participant_texts

MAX_QUESTIONS, MAX_CHOICES, MAX_TEXT = 20, 8, 500
MAX_ATTEMPTS = 10  # more tries than this is no check at all


class QuestionsError(ValueError):
    """A question a researcher wrote that cannot be asked: one line, naming the question."""


def defaults(domain) -> list[dict]:
    """The domain's own questions, as a study stores them."""
    return [{"question": q.text, "choices": list(q.choices), "right": list(q.right)}
            for q in participant_texts(domain).comprehension]


def questions_of(study) -> list[dict]:
    """The questions `study` asks: its own, else its domain's."""
    if study.comprehension_questions:
        return study.comprehension_questions
    from ..trajectories import study_domain  # noqa: PLC0415  (teaching loads only for a page)

    return defaults(study_domain(study))


def format_text(questions: list[dict]) -> str:
    """The designer's text of `questions` (parse_text's format)."""
    blocks = []
    for q in questions:
        lines = [q["question"]] + [("* " if k in q["right"] else "- ") + c for k, c in enumerate(q["choices"])]
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def parse_text(text: str) -> list[dict]:
    """The questions of the designer's text (the module's format); QuestionsError, one line, for a question
    that cannot be asked.  Empty text: no questions of the study's own ([])."""
    blocks = [b for b in (text or "").replace("\r\n", "\n").split("\n\n") if b.strip()]
    out = []
    for number, block in enumerate(blocks, 1):
        lines = [line.strip() for line in block.strip().split("\n") if line.strip()]
        question, choices, right = lines[0], [], []
        if question[:2] in ("* ", "- "):
            raise QuestionsError(f"question {number} starts with a choice: write the question on its first line")
        for line in lines[1:]:
            if line[:2] not in ("* ", "- "):
                raise QuestionsError(f"question {number}: each choice starts with '* ' (right) or '- ' (wrong), "
                                     f"not {line[:40]!r}")
            if line.startswith("* "):
                right.append(len(choices))
            choices.append(line[2:].strip())
        out.append({"question": question, "choices": choices, "right": right})
    return check(out)


def check(questions) -> list[dict]:
    """`questions` as stored ({"question", "choices", "right"} each), checked; QuestionsError otherwise."""
    if not isinstance(questions, list):
        raise QuestionsError("the questions are a list of {question, choices, right}")
    if len(questions) > MAX_QUESTIONS:
        raise QuestionsError(f"at most {MAX_QUESTIONS} questions (got {len(questions)})")
    out = []
    for number, q in enumerate(questions, 1):
        if not isinstance(q, dict) or not isinstance(q.get("question"), str) or not q["question"].strip():
            raise QuestionsError(f"question {number} needs its text")
        choices, right = q.get("choices"), q.get("right")
        if not isinstance(choices, list) or not all(isinstance(c, str) and c.strip() for c in choices):
            raise QuestionsError(f"question {number}: its choices are a list of texts")
        if len(choices) < 2:
            raise QuestionsError(f"question {number} needs at least 2 choices (got {len(choices)})")
        if len(choices) > MAX_CHOICES:
            raise QuestionsError(f"question {number}: at most {MAX_CHOICES} choices (got {len(choices)})")
        if any(len(t) > MAX_TEXT for t in (q["question"], *choices)):
            raise QuestionsError(f"question {number}: a text longer than {MAX_TEXT} characters")
        if not isinstance(right, list) or not right:
            raise QuestionsError(f"question {number} has no right answer: mark one with '* '")
        if not all(isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(choices) for k in right):
            raise QuestionsError(f"question {number}: its right answers are indices of its choices")
        if len(set(right)) == len(choices):
            raise QuestionsError(f"question {number}: every choice is right, so it checks nothing")
        out.append({"question": q["question"].strip(), "choices": [c.strip() for c in choices],
                    "right": sorted(set(right))})
    return out


def missed(questions: list[dict], answers: list[list[int]]) -> list[int]:
    """Indices of the questions whose ticked choices are not exactly the right ones."""
    return [i for i, (q, a) in enumerate(zip(questions, answers, strict=True)) if sorted(a) != q["right"]]


class ComprehensionForm(forms.Form):
    """The questions' answers (``q<i>``: the positions of the choices ticked) and which attempt they are
    (``attempt``: the page's, so a replayed post is told apart from a new attempt)."""

    attempt = WholeNumberField(min_value=1, error_messages={
        "required": _("This page was incomplete; please reload it."),
        "invalid": _("This page was incomplete; please reload it."),
        "min_value": _("This page was incomplete; please reload it.")})

    def __init__(self, data, participant, step):
        super().__init__(data)
        self.questions = questions_of(participant.study)
        for i, q in enumerate(self.questions):
            self.fields[f"q{i}"] = forms.TypedMultipleChoiceField(
                coerce=int, choices=[(str(k), c) for k, c in enumerate(q["choices"])], error_messages={
                    "required": gettext("Please answer every question: question {n} has no answer yet.").format(
                        n=i + 1),
                    "invalid_choice": gettext("Question {n}: please choose among its answers.").format(n=i + 1)})

    def clean(self):
        data = super().clean()
        for i, q in enumerate(self.questions):  # a question with one right answer is a radio: one choice
            if len(q["right"]) == 1 and len(data.get(f"q{i}") or ()) > 1:
                self.add_error(f"q{i}", gettext("Question {n}: please choose one answer.").format(n=i + 1))
        return data

    def first_error(self) -> str:
        return next(message for messages in self.errors.values() for message in messages)

    def answer(self) -> dict:
        return {"attempt": self.cleaned_data["attempt"],
                "answers": [sorted(self.cleaned_data[f"q{i}"]) for i in range(len(self.questions))]}


def page_context(participant) -> dict:
    """What the step's page shows: the questions (texts and choices, never which are right), the missed
    questions of the last failed attempt, and how many tries are left."""
    questions = questions_of(participant.study)
    attempts = list(participant.comprehension_attempts.order_by("number").values("number", "missed", "passed"))
    last = attempts[-1] if attempts else None
    missed_now = set(last["missed"]) if last and not last["passed"] else set()
    return {
        "questions": [{"index": i, "number": i + 1, "text": q["question"], "choices": list(enumerate(q["choices"])),
                       "several": len(q["right"]) > 1, "missed": i in missed_now} for i, q in enumerate(questions)],
        "missed_questions": [questions[i]["question"] for i in sorted(missed_now)],
        "attempt": len(attempts) + 1,
        "tries_left": participant.study.comprehension_attempts - len(attempts),
    }
