"""A participant's status: the one place that decides how each participant's study ended.

The exports' ``status`` column, the dashboard's counts and the analysis (its per-participant table and
the headline ``manage.py analyze`` prints) all call :func:`participant_status`, so a researcher who keeps
only ``status == complete`` from an export has exactly the participants the app analyses by default.

No Django import: it works on plain values (a ``values()`` row, a DataFrame row).
"""
from __future__ import annotations

COMPLETE, INCOMPLETE, EXCLUDED, DECLINED = "complete", "incomplete", "excluded", "declined"
# Set on the participant's row when it happens (Participant.outcome, studyapp.participant.outcomes); the values are
# the row's own, so an export's status and its stored outcome read alike.
RETURNED, TIMED_OUT, SCREENED_OUT = "returned", "timed_out", "screened_out"
ENDED = (RETURNED, TIMED_OUT, SCREENED_OUT)
STATUSES = (COMPLETE, INCOMPLETE, EXCLUDED, DECLINED, *ENDED)

# What each status means; the data dictionary and docs/study.md quote these.
MEANINGS = {
    COMPLETE: "answered every step and passed the attention check: the analysed set",
    INCOMPLETE: "gave consent but stopped before the end (n_tests_answered says how far); not analysed",
    EXCLUDED: "failed the attention check (finished or not); kept in the data, not analysed",
    DECLINED: "never gave consent (declined, or left on the consent page); nothing may be analysed",
    RETURNED: "the recruiting platform says they returned (withdrew from) the study; kept, not analysed",
    TIMED_OUT: "did not finish within the study's time limit; their place was freed; kept, not analysed",
    SCREENED_OUT: "failed the comprehension check too often; kept, not analysed",
}


def participant_status(*, position: int, excluded: bool, completed: bool, outcome: str = "") -> str:
    """The status of one participant from their row's ``position``, ``excluded``, whether
    ``completed_at`` is set, and ``outcome``.

    An outcome the row records (returned, timed out, screened out) is the status whatever else holds:
    a participant the platform says returned the study has withdrawn, finished or not.  Consent is step 0
    of every flow (studyapp.participant.flow.steps_for) and ``position`` moves past a step only when its answer is
    stored, so ``position == 0`` means no consent was ever given.  Failing the attention check excludes
    a participant whether or not they went on to finish (as in the analysis, which drops every excluded
    participant)."""
    if outcome:
        if outcome not in ENDED:
            raise ValueError(f"unknown outcome {outcome!r}; expected one of {', '.join(ENDED)}")
        return outcome
    if position <= 0:
        return DECLINED
    if excluded:
        return EXCLUDED
    return COMPLETE if completed else INCOMPLETE
