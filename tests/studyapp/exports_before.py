"""The exporter as it was before the exports were streamed (main at 3dada65, studyapp/exports.py), kept verbatim as
the reference the streamed exports are compared with: an independent, object-at-a-time implementation
(select_related + prefetch), so a row the new code writes differently shows up in the tests."""
import csv
import io
import json

from studyapp.data.exports import LONG_COLUMNS, N_TESTS_WIDE, WIDE_COLUMNS
from studyapp.models import Answer, Participant, StepKind, Study

# The columns the old files had: every one but those added since (how each participant's study ended).
NEW = ("status", "ended_at", "completion_code", "bonus")
LONG_COLUMNS = [c for c in LONG_COLUMNS if c[0] not in NEW]
WIDE_COLUMNS = [c for c in WIDE_COLUMNS if c[0] not in NEW]


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


# A spreadsheet runs a cell that starts with one of these as a formula (OWASP "CSV injection").
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def neutralise(value):
    """Text that a spreadsheet would read as a formula gets a leading single quote.

    Only strings: they are what participants typed (platform ids, gender_text); numbers, such as a
    confidence score of -5, are written as numbers and stay untouched.
    """
    if isinstance(value, str) and value.startswith(FORMULA_STARTS):
        return "'" + value
    return value


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
