"""A participant's status: the one place that decides complete / incomplete / excluded / declined.

The exports' ``status`` column and the analysis (its per-participant table and the headline
``manage.py analyze`` prints) both call :func:`participant_status`, so a researcher who keeps only
``status == complete`` from an export has exactly the participants the app analyses by default.

No Django import: it works on plain values (a ``values()`` row, a DataFrame row).
"""
from __future__ import annotations

COMPLETE, INCOMPLETE, EXCLUDED, DECLINED = "complete", "incomplete", "excluded", "declined"
STATUSES = (COMPLETE, INCOMPLETE, EXCLUDED, DECLINED)

# What each status means; the data dictionary and docs/study.md quote these.
MEANINGS = {
    COMPLETE: "answered every step and passed the attention check: the analysed set",
    INCOMPLETE: "gave consent but stopped before the end (n_tests_answered says how far); not analysed",
    EXCLUDED: "failed the attention check (finished or not); kept in the data, not analysed",
    DECLINED: "never gave consent (declined, or left on the consent page); nothing may be analysed",
}


def participant_status(*, position: int, excluded: bool, completed: bool) -> str:
    """The status of one participant from their row's ``position``, ``excluded`` and whether
    ``completed_at`` is set.

    Consent is step 0 of every flow (studyapp.flow.steps_for) and ``position`` moves past a step
    only when its answer is stored, so ``position == 0`` means no consent was ever given.  Failing
    the attention check excludes a participant whether or not they went on to finish (as in the
    analysis, which drops every excluded participant)."""
    if position <= 0:
        return DECLINED
    if excluded:
        return EXCLUDED
    return COMPLETE if completed else INCOMPLETE
