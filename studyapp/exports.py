"""CSV exports of a study: long (one row per answer), wide (one row per participant), and the data dictionary.

Staff previews are never exported.  Excluded participants (failed
attention check) are exported with ``excluded = 1`` so analyses can drop them.
"""
from __future__ import annotations

import csv
import io
import json

from .csvsafe import FORMULA_STARTS, neutralise  # noqa: F401  (the guard; exports.neutralise stays importable)
from .models import Answer, Participant, StepKind, Study

# (column, description) — the data dictionary; the same text is in docs/study.md.
PARTICIPANT_COLUMNS = [
    ("participant_id", "Database id of the participant (stable, pseudonymous)."),
    ("study", "Study slug."),
    ("condition", "Condition name (the training sequence shown)."),
    ("platform", "prolific, mturk or anonymous."),
    ("platform_pid", "PROLIFIC_PID (Prolific) or workerId (MTurk); empty when anonymous."),
    ("platform_study_id", "STUDY_ID (Prolific) or hitId (MTurk)."),
    ("platform_session_id", "SESSION_ID (Prolific) or assignmentId (MTurk) of the first arrival."),
    ("platform_session_ids", "Every SESSION_ID / assignmentId the participant arrived with, ';'-separated."),
    ("started_at", "UTC time of the first arrival (ISO 8601)."),
    ("completed_at", "UTC time the last answer was stored; empty if unfinished."),
    ("excluded", "1 if the attention check was failed (keep in data, drop from analysis)."),
]
LONG_COLUMNS = PARTICIPANT_COLUMNS + [
    ("step", "Index of the step in the participant's flow (0 = consent)."),
    ("kind", "consent, instructions, training, test, attention or demographics."),
    ("item", "Index of the training environment or test (0-based) within its kind; empty otherwise."),
    ("env_id", "Environment id (teaching.environments enumeration) for training and test rows."),
    ("chosen_option", "Test: canonical index (0-3) of the option chosen as matching the car's style."),
    ("chosen_display_position", "Test: position (0-3, shown as A-D) at which the chosen option was displayed."),
    ("chosen_is_theta_star", "Test: 1 if the chosen option is theta*'s trajectory."),
    ("chosen_rating", "Test: the 1-7 rating given to the chosen option."),
    ("confidence_score", "Test: chosen_rating if chosen_is_theta_star else -chosen_rating."),
    ("rating_0", "Test: 1-7 rating of canonical option 0 (rating_1..rating_3 likewise)."),
    ("rating_1", "Test: rating of canonical option 1."),
    ("rating_2", "Test: rating of canonical option 2."),
    ("rating_3", "Test: rating of canonical option 3."),
    ("theta_star_option", "Test: canonical index of theta*'s option."),
    ("display_order", "Test: canonical option indices in the order displayed (A first), space separated."),
    ("answer_json", "The stored answer exactly as saved (JSON)."),
    ("answered_at", "UTC time the answer was stored."),
]
N_TESTS_WIDE = 6
WIDE_COLUMNS = PARTICIPANT_COLUMNS + [
    ("attention_passed", "1 if exactly the two goals (merge right, drive forward) were chosen."),
    ("attention_goals", "Goals chosen in the attention check, space separated."),
    ("age", "Self-reported age in years."),
    ("gender", "Self-reported gender (female, male, non-binary, other, undisclosed)."),
    ("gender_text", "Self-description when gender is 'other'."),
    ("n_training", "Number of training environments in the participant's condition."),
    ("n_tests_answered", "Number of tests answered."),
    ("mean_confidence_score", "Mean confidence score over the answered tests (the paper's dependent measure)."),
    ("n_correct", "Number of tests where theta*'s option was chosen."),
] + [col for j in range(N_TESTS_WIDE) for col in (
    (f"test{j}_env_id", f"Test {j}: environment id."),
    (f"test{j}_correct", f"Test {j}: 1 if theta*'s option was chosen."),
    (f"test{j}_confidence_score", f"Test {j}: confidence score (-7..7)."),
)]


def _participant_fields(p: Participant) -> dict:
    return {
        "participant_id": p.pk, "study": p.study.slug, "condition": p.condition.name, "platform": p.platform,
        "platform_pid": p.platform_pid, "platform_study_id": p.platform_study_id,
        "platform_session_id": p.platform_session_id, "platform_session_ids": ";".join(p.platform_session_ids),
        "started_at": p.started_at.isoformat(),
        "completed_at": p.completed_at.isoformat() if p.completed_at else "", "excluded": int(p.excluded),
    }


def _participants(study: Study):
    return (Participant.objects.filter(study=study).exclude(platform=Participant.PREVIEW)
            .select_related("study", "condition").prefetch_related("answers").order_by("pk"))


def _test_fields(study: Study, answer: Answer) -> dict:
    data = answer.data
    options = study.test_set[answer.item]["options"]
    star = next(k for k, o in enumerate(options) if o["is_theta_star"])
    choice = data["choice"]
    fields = {
        "chosen_option": choice, "chosen_display_position": data["order"].index(choice),
        "chosen_is_theta_star": int(choice == star), "chosen_rating": data["ratings"][choice],
        "confidence_score": answer.confidence_score, "theta_star_option": star,
        "display_order": " ".join(str(k) for k in data["order"]),
    }
    fields.update({f"rating_{k}": r for k, r in enumerate(data["ratings"])})
    return fields


def long_rows(study: Study):
    for p in _participants(study):
        base = _participant_fields(p)
        for a in sorted(p.answers.all(), key=lambda a: a.step):
            row = dict(base, step=a.step, kind=a.kind, item="" if a.item is None else a.item,
                       env_id=a.data.get("env_id", ""), answer_json=json.dumps(a.data, sort_keys=True),
                       answered_at=a.created_at.isoformat())
            if a.kind == StepKind.TEST:
                row.update(_test_fields(study, a))
            yield row


def wide_rows(study: Study):
    for p in _participants(study):
        row = _participant_fields(p)
        answers = {(a.kind, a.item): a for a in p.answers.all()}
        attention = answers.get((StepKind.ATTENTION, None))
        demo = answers.get((StepKind.DEMOGRAPHICS, None))
        tests = sorted((a for a in answers.values() if a.kind == StepKind.TEST), key=lambda a: a.item)
        scores = [a.confidence_score for a in tests]
        row.update(
            attention_passed="" if attention is None else int(attention.data["passed"]),
            attention_goals="" if attention is None else " ".join(attention.data["goals"]),
            age="" if demo is None else demo.data["age"], gender="" if demo is None else demo.data["gender"],
            gender_text="" if demo is None else demo.data.get("gender_text", ""),
            n_training=len(p.condition.training), n_tests_answered=len(tests),
            mean_confidence_score=round(sum(scores) / len(scores), 6) if scores else "",
            n_correct=sum(int(a.correct) for a in tests))
        for a in tests:
            row.update({f"test{a.item}_env_id": a.data["env_id"], f"test{a.item}_correct": int(a.correct),
                        f"test{a.item}_confidence_score": a.confidence_score})
        yield row


def to_csv(columns, rows) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=[c for c, _ in columns], extrasaction="raise", restval="")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: neutralise(v) for k, v in row.items()})
    return out.getvalue()


def long_csv(study: Study) -> str:
    return to_csv(LONG_COLUMNS, long_rows(study))


def wide_csv(study: Study) -> str:
    columns = list(WIDE_COLUMNS)
    extra = len(study.test_set) - N_TESTS_WIDE
    for j in range(N_TESTS_WIDE, N_TESTS_WIDE + max(extra, 0)):
        columns += [(f"test{j}_env_id", ""), (f"test{j}_correct", ""), (f"test{j}_confidence_score", "")]
    return to_csv(columns, wide_rows(study))


def dictionary_csv() -> str:
    rows = [{"file": "long", "column": c, "description": d} for c, d in LONG_COLUMNS]
    rows += [{"file": "wide", "column": c, "description": d} for c, d in WIDE_COLUMNS]
    return to_csv([("file", ""), ("column", ""), ("description", "")], rows)
