"""The columns of a study's CSV exports and what each holds: the data dictionary (studyapp/data/exports.py writes
the files, docs/study.md quotes the same text)."""
from __future__ import annotations

from ..status import MEANINGS, STATUSES

# (column, description) — the data dictionary; the same text is in docs/study.md.
PARTICIPANT_COLUMNS = [
    ("participant_id", "Database id of the participant (stable, pseudonymous)."),
    ("study", "Study slug."),
    ("condition", "Condition name (the training sequence shown)."),
    ("platform", "prolific, mturk or anonymous."),
    ("platform_pid", "PROLIFIC_PID (Prolific) or workerId (MTurk); empty when anonymous. In a pseudonymised "
                     "export (for sharing) this and the session ids are stable pseudonyms, p-<16 hex digits>."),
    ("platform_study_id", "STUDY_ID (Prolific) or hitId (MTurk)."),
    ("platform_session_id", "SESSION_ID (Prolific) or assignmentId (MTurk) of the first arrival."),
    ("platform_session_ids", "Every SESSION_ID / assignmentId the participant arrived with, ';'-separated."),
    ("started_at", "UTC time of the first arrival (ISO 8601)."),
    ("completed_at", "UTC time the last answer was stored; empty if unfinished."),
    ("excluded", "1 if the attention check was failed (status 'excluded'). Not the filter for an analysis: "
                 "use status."),
    ("status", ", ".join(STATUSES) + ". Analyse only status == complete: exactly the participants the app "
               "analyses. " + "; ".join(f"{k}: {v}" for k, v in MEANINGS.items()) + "."),
    ("ended_at", "UTC time the participant returned, timed out or was screened out; empty otherwise."),
    ("completion_code", "The code the participant was given (each outcome may have its own: the study's codes); "
                        "empty if none, and in a pseudonymised export."),
    ("bonus", "The performance bonus earned (the study's currency), computed once on finishing; empty if "
              "unfinished. Paid only to status == complete (the bulk-bonus files)."),
]
LONG_COLUMNS = PARTICIPANT_COLUMNS + [
    ("step", "Index of the step in the participant's flow (0 = consent)."),
    ("kind", "consent, instructions, training, test, attention or demographics; in a closed-loop condition also "
             "check and feedback; in a study with a comprehension check also comprehension (a row per attempt)."),
    ("item", "Index of the training environment or test (0-based) within its kind; in a closed-loop condition a "
             "training, check or feedback step's index within the loop; a comprehension attempt's number (from 1); "
             "empty otherwise."),
    ("env_id", "Environment id (the study's domain's enumeration; a study's dictionary names it) for training and "
               "test rows; in a closed-loop condition also for check and feedback rows."),
    ("chosen_option", "Test or check: canonical index (0-3) of the option chosen as matching the robot."),
    ("chosen_display_position", "Test or check: position (0-3, shown as A-D) at which the chosen option was "
                                "displayed."),
    ("chosen_is_theta_star", "Test or check: 1 if the chosen option is theta*'s trajectory."),
    ("chosen_rating", "Test or check: the 1-7 rating given to the chosen option."),
    ("confidence_score", "Test or check: chosen_rating if chosen_is_theta_star else -chosen_rating."),
    ("rating_0", "Test or check: 1-7 rating of canonical option 0 (rating_1..rating_3 likewise)."),
    ("rating_1", "Test or check: rating of canonical option 1."),
    ("rating_2", "Test or check: rating of canonical option 2."),
    ("rating_3", "Test or check: rating of canonical option 3."),
    ("theta_star_option", "Test or check: canonical index of theta*'s option."),
    ("test_difficulty", "Test: low, medium or high when the study's tests were graded by difficulty (the "
                        "tertile of the environment's behaviour-equivalence class size among the eligible "
                        "ones: a large class is low); empty for ungraded tests and for checks."),
    ("display_order", "Test or check: canonical option indices in the order displayed (A first), space separated."),
    ("answer_json", "The stored answer exactly as saved (JSON)."),
    ("answered_at", "UTC time the answer was stored."),
]
N_TESTS_WIDE = 6
WIDE_COLUMNS = PARTICIPANT_COLUMNS + [
    ("attention_passed", "1 if exactly the right answers were ticked (its domain's; a study's dictionary names "
                         "them)."),
    ("attention_goals", "Answers ticked in the attention check (its domain's values), space separated."),
    ("age", "Self-reported age in years."),
    ("gender", "Self-reported gender (female, male, non-binary, other, undisclosed)."),
    ("gender_text", "Self-description when gender is 'other'."),
    ("n_training", "Number of training environments in the participant's condition."),
    ("n_tests_answered", "Number of tests answered."),
    ("mean_confidence_score", "Mean confidence score over the tests (the paper's dependent measure); empty "
                              "unless every test was answered (status complete or excluded): an incomplete "
                              "participant's testJ_confidence_score columns still hold what they answered."),
    ("n_correct", "Number of tests where theta*'s option was chosen."),
] + [col for j in range(N_TESTS_WIDE) for col in (
    (f"test{j}_env_id", f"Test {j}: environment id."),
    (f"test{j}_correct", f"Test {j}: 1 if theta*'s option was chosen."),
    (f"test{j}_confidence_score", f"Test {j}: confidence score (-7..7)."),
)]
# Studies with closed-loop conditions only, after the test columns: check<k> for k = 1 .. the most checks any of
# its closed-loop conditions asks (closedloop.max_checks); empty in a condition without checks.
CHECK_SUMMARY_COLUMNS = [
    ("n_checks_answered", "Closed-loop conditions: number of check questions answered (empty in other conditions)."),
    ("n_checks_correct", "Closed-loop conditions: number of check questions where theta*'s option was chosen."),
]


def check_columns(k) -> list[tuple[str, str]]:
    """The wide file's columns of the participant's k-th check question (k = 1, 2, ...; "<k>" in the dictionary)."""
    return [(f"check{k}_env_id", f"Check {k} (the participant's k-th check question, k = 1, 2, ...): environment id."),
            (f"check{k}_correct", f"Check {k}: 1 if theta*'s option was chosen."),
            (f"check{k}_confidence_score", f"Check {k}: confidence score (-7..7).")]
