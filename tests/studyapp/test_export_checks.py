"""Check answers of closed-loop conditions in the exports: the long file fills a check's row
as a test's, the wide file has per-check columns, and the long export still costs a fixed number of queries
per page of participants, whatever their number."""
import csv
import io
import re
from pathlib import Path

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext

from studyapp.analysis.simulate import run_participant, simulate
from studyapp.data import exports
from studyapp.models import Answer, LoopStep, StepKind
from studyapp.participant import assignment, closedloop

pytestmark = pytest.mark.django_db
DOCS = Path(__file__).resolve().parents[2] / "docs" / "study.md"


def rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def test_check_rows_of_the_long_file_are_filled_as_tests(closed_loop_study):
    study = closed_loop_study
    simulate(study, n_per_condition=3, fail_every=100)
    checks = [r for r in rows(exports.long_csv(study)) if r["kind"] == StepKind.CHECK]
    stored = {(a.participant_id, a.item): a for a in Answer.objects.filter(kind=StepKind.CHECK)}
    assert checks and len(checks) == len(stored)
    questions = study.conditions.get(name="closed-loop").closed_loop["checks"]
    for r in checks:
        a = stored[int(r["participant_id"]), int(r["item"])]
        question = questions[LoopStep.objects.get(participant_id=a.participant_id, index=a.item).question]
        star = next(k for k, o in enumerate(question["options"]) if o["is_theta_star"])
        assert r["chosen_is_theta_star"] == str(int(a.correct))
        assert r["theta_star_option"] == str(star) and r["env_id"] == str(question["env_id"])
        assert (r["chosen_option"], r["confidence_score"]) == (str(a.data["choice"]), str(a.confidence_score))
        assert r["chosen_rating"] == str(a.data["ratings"][a.data["choice"]])
        assert r["chosen_display_position"] == str(a.data["order"].index(a.data["choice"]))
        assert r["display_order"] == " ".join(map(str, a.data["order"]))
    feedback = [r for r in rows(exports.long_csv(study)) if r["kind"] == StepKind.FEEDBACK]
    assert feedback and all(r["chosen_option"] == r["theta_star_option"] == "" for r in feedback)


def test_the_wide_file_counts_each_participants_checks(closed_loop_study):
    study = closed_loop_study
    simulate(study, n_per_condition=3, fail_every=100)
    loop = study.conditions.get(name="closed-loop").closed_loop
    n_checks = closedloop.max_checks(loop)
    assert n_checks >= 2
    out = rows(exports.wide_csv(study))
    header = list(out[0].keys())
    n_tests = len(study.test_set)
    assert header[:header.index(f"test{n_tests - 1}_confidence_score") + 1] == [c for c, _ in exports.WIDE_COLUMNS]
    assert header[len(exports.WIDE_COLUMNS):] == ["n_checks_answered", "n_checks_correct"] + [
        f"check{k}_{c}" for k in range(1, n_checks + 1) for c in ("env_id", "correct", "confidence_score")]
    for r in out:
        answers = Answer.objects.filter(participant_id=int(r["participant_id"]), kind=StepKind.CHECK).order_by("step")
        if r["condition"] != "closed-loop":
            assert r["n_checks_answered"] == r["n_checks_correct"] == r["check1_correct"] == ""
            continue
        assert int(r["n_checks_correct"]) == sum(a.correct for a in answers)
        assert int(r["n_checks_answered"]) == answers.count() >= 1
        for k, a in enumerate(answers, start=1):
            assert (r[f"check{k}_env_id"], r[f"check{k}_correct"], r[f"check{k}_confidence_score"]) == (
                str(a.data["env_id"]), str(int(a.correct)), str(a.confidence_score))


def test_a_study_without_closed_loop_keeps_its_columns_and_queries(study, complete):
    complete(assignment.assign(study, "prolific", "N1"))
    assert list(rows(exports.wide_csv(study))[0].keys()) == [c for c, _ in exports.WIDE_COLUMNS]
    with CaptureQueriesContext(connection) as long_queries:
        exports.long_csv(study)
    assert not [q for q in long_queries.captured_queries if "loopstep" in q["sql"].lower()]


def count_long_queries(study) -> int:
    with CaptureQueriesContext(connection) as queries:
        text = exports.long_csv(study)
    assert any(r["kind"] == StepKind.CHECK and r["theta_star_option"] != "" for r in rows(text))
    return len(queries.captured_queries)


def test_the_long_export_queries_do_not_grow_with_participants(closed_loop_study, monkeypatch):
    study = closed_loop_study
    rng = simulate(study, n_per_condition=3, fail_every=100)  # 6 participants, 3 in the closed loop
    few = count_long_queries(study)
    for _ in range(10):
        run_participant(study, rng)
    assert study.participants.count() == 16
    assert count_long_queries(study) == few <= 5  # conditions; one page: people, answers, loop steps; the end
    monkeypatch.setattr(exports, "PAGE", 4)  # 4 pages of 4 participants: three queries a page, the end
    assert count_long_queries(study) == few + 3 * 3


def test_the_dictionary_describes_the_check_columns():
    d = {(r["file"], r["column"]): r["description"] for r in rows(exports.dictionary_csv())}
    for column in ("n_checks_answered", "n_checks_correct", "check<k>_env_id", "check<k>_correct",
                   "check<k>_confidence_score"):
        assert d[("wide", column)]
    assert d[("long", "theta_star_option")].startswith("Test or check:")
    doc = DOCS.read_text()  # docs/study.md's dictionary has the same rows
    for column, _ in exports.CHECK_SUMMARY_COLUMNS + exports.check_columns(1):
        assert f"| `{re.sub(r'^check[0-9]+_', 'check<k>_', column)}` |" in doc, column
