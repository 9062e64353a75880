"""The export columns of a study with a comprehension check (``Study.comprehension_check``): every attempt
at it is a row of the long file (kind "comprehension", item = the attempt's number), and the wide file says
how many attempts a participant made and whether they passed.

Kept apart from :mod:`studyapp.data.exports` so that a study without the check has exactly the files, columns
and queries it had: these appear only in the files of a study that asks it.
"""
from __future__ import annotations

from ..models import ComprehensionAttempt, StepKind

# plain strs, as the answer rows carry them: an attempt's row is of the check's kind
COMPREHENSION, INSTRUCTIONS = StepKind.COMPREHENSION.value, StepKind.INSTRUCTIONS.value

# Long file: after answered_at; empty on the rows of other steps.
COMPREHENSION_LONG_COLUMNS = [
    ("comprehension_passed", "Studies with a comprehension check, its rows only (kind comprehension, one per "
                             "attempt, item = the attempt's number from 1): 1 if every question was answered "
                             "right, else 0; answer_json holds the choices ticked per question (answers: their "
                             "0-based positions), the questions missed (missed: 0-based) and passed."),
]
# Wide file: after every other column.
COMPREHENSION_WIDE_COLUMNS = [
    ("comprehension_attempts", "Studies with a comprehension check: how many attempts the participant made at it "
                               "(0: they never reached it)."),
    ("comprehension_passed", "Studies with a comprehension check: 1 if an attempt passed, 0 if every attempt failed "
                             "(screened out after the study's number of attempts, or stopped); empty without "
                             "attempts."),
]


def attempts_of(people: list[dict]) -> dict[int, list[dict]]:
    """{participant id: their attempts in order, each as a long-file answer row} of a page of participants:
    one query.  An attempt stands at its step (`step`, set by the caller) as the check's answer would."""
    out: dict[int, list[dict]] = {}
    rows = (ComprehensionAttempt.objects.filter(participant_id__in=[p["pk"] for p in people])
            .order_by("participant_id", "number")
            .values("participant_id", "number", "answers", "missed", "passed", "created_at"))
    for a in rows:
        out.setdefault(a["participant_id"], []).append({
            "kind": COMPREHENSION, "item": a["number"], "passed": int(a["passed"]), "created_at": a["created_at"],
            "data": {"answers": a["answers"], "missed": a["missed"], "passed": a["passed"]}})
    return out


def with_attempts(answers: list[dict], attempts: list[dict]) -> list[dict]:
    """A participant's long-file rows: their answers, the check's own answer replaced by every attempt, at
    the check's step (its answer's, else the step after the instructions: a participant screened out has none)."""
    step = next((a["step"] for a in answers if a["kind"] == COMPREHENSION),
                next((a["step"] + 1 for a in answers if a["kind"] == INSTRUCTIONS), 2))
    rows = [a for a in answers if a["kind"] != COMPREHENSION] + [{**a, "step": step} for a in attempts]
    return sorted(rows, key=lambda a: a["step"])  # stable: the attempts stay in their order


def wide_fields(attempts: list[dict]) -> dict:
    """The wide file's comprehension columns of one participant's attempts."""
    passed = "" if not attempts else int(any(a["passed"] for a in attempts))
    return {"comprehension_attempts": len(attempts), "comprehension_passed": passed}
