"""CSV exports: long = one row per answer, wide = one row per participant, columns = the data dictionary."""
import csv
import io

import pytest

from studyapp.data import exports
from studyapp.models import Participant, StepKind
from studyapp.participant import assignment, flow
from studyapp.researcher.studies import make_study

pytestmark = pytest.mark.django_db


def rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def test_long_export_one_row_per_answer(study, complete):
    p = complete(assignment.assign(study, "prolific", "L1", platform_study_id="S", platform_session_id="X"),
            choices=[0] * 6)
    out = rows(exports.long_csv(study))
    assert len(out) == p.answers.count() == len(flow.steps_for(p)) - 1
    assert list(out[0].keys()) == [c for c, _ in exports.LONG_COLUMNS]
    tests = [r for r in out if r["kind"] == StepKind.TEST]
    assert len(tests) == 6
    for r in tests:
        j = int(r["item"])
        options = study.test_set[j]["options"]
        star = next(k for k, o in enumerate(options) if o["is_theta_star"])
        rating = 6 if star == 0 else 2
        assert r["chosen_option"] == "0" and r["theta_star_option"] == str(star)
        assert int(r["confidence_score"]) == (rating if star == 0 else -rating)
        assert r["chosen_rating"] == str(rating)
        assert int(r["chosen_display_position"]) == p.option_orders[j].index(0)
        assert r["display_order"] == " ".join(map(str, p.option_orders[j]))
        assert r["env_id"] == str(study.test_set[j]["env_id"])
        assert r["test_difficulty"] == ""  # its tests were not graded
    assert out[0]["platform_session_id"] == "X" and out[0]["excluded"] == "0"


def test_a_graded_tests_difficulty_is_in_the_long_export_and_its_dictionary(demo_table, complete):
    graded = make_study(demo_table, "graded", difficulty="high")
    assert {t["difficulty"] for t in graded.test_set} == {"high"}
    complete(assignment.assign(graded, "link", "G1"))
    out = rows(exports.long_csv(graded))
    assert [r["test_difficulty"] for r in out if r["kind"] == StepKind.TEST] == ["high"] * 6
    assert {r["test_difficulty"] for r in out if r["kind"] != StepKind.TEST} == {""}
    dictionary = {r["column"]: r["description"] for r in rows(exports.dictionary_csv(graded)) if r["file"] == "long"}
    assert "low, medium or high" in dictionary["test_difficulty"]


def test_wide_export_one_row_per_participant(study, complete):
    complete(assignment.assign(study, "prolific", "W1"))  # all theta*, rated 6
    complete(assignment.assign(study, "prolific", "W2"), attentive=False)
    complete(assignment.assign(study, "prolific", "W3"), stop_before=StepKind.TEST)  # unfinished
    assignment.preview_participant(study.conditions.first())
    out = {r["platform_pid"]: r for r in rows(exports.wide_csv(study))}
    assert set(out) == {"W1", "W2", "W3"}
    assert list(out["W1"].keys()) == [c for c, _ in exports.WIDE_COLUMNS]
    w1 = out["W1"]
    assert ((w1["mean_confidence_score"], w1["n_correct"], w1["attention_passed"], w1["excluded"])
            == ("6.0", "6", "1", "0"))
    assert (w1["age"], w1["gender"], w1["test5_confidence_score"]) == ("34", "female", "6")
    assert (out["W2"]["attention_passed"], out["W2"]["excluded"], out["W2"]["attention_goals"]) == ("0", "1", "forward")
    assert out["W3"]["completed_at"] == "" and out["W3"]["n_tests_answered"] == "0"


def test_data_dictionary_covers_every_column():
    d = rows(exports.dictionary_csv())
    described = {(r["file"], r["column"]) for r in d if r["description"]}
    assert {("long", c) for c, _ in exports.LONG_COLUMNS} <= described
    assert {("wide", c) for c, _ in exports.WIDE_COLUMNS} <= described


def test_confidence_score_is_derivable_from_the_raw_answer(study, complete):
    p = complete(assignment.assign(study, "prolific", "D1"), choices=[1, 2, 3, 0, 1, 2])
    for a in p.answers.filter(kind=StepKind.TEST):
        options = study.test_set[a.item]["options"]
        rating = a.data["ratings"][a.data["choice"]]
        expected = rating if options[a.data["choice"]]["is_theta_star"] else -rating
        assert a.confidence_score == expected and a.correct == options[a.data["choice"]]["is_theta_star"]
    assert Participant.objects.get().completed_at is not None
