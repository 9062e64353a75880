"""The comprehension check after the instructions (studyapp/participant/comprehension.py): a wrong answer sends the
participant back to the instructions with the questions they missed named, the right ones let them go on,
too many failures screen them out with the study's code; every attempt is stored once, exported, and
erased with the participant; the designer and the spec refuse questions that cannot be asked."""
from __future__ import annotations

import csv
import io
import re

import pytest
from django.urls import reverse

from studyapp import status
from studyapp.data import exports, privacy
from studyapp.models import Answer, ComprehensionAttempt, Participant, StepKind
from studyapp.participant import assignment, comprehension, flow
from studyapp.researcher.specschema import SpecError, check_spec
from teaching.api import domain_names, get_domain

pytestmark = pytest.mark.django_db

QUESTIONS = [{"question": "What comes first?", "choices": ["Questions", "Examples", "Nothing"], "right": [1]},
             {"question": "Which are colours?", "choices": ["red", "seven", "blue"], "right": [0, 2]}]
RIGHT = {"q0": ["1"], "q1": ["0", "2"]}
WRONG = {"q0": ["0"], "q1": ["0", "2"]}  # the first question missed


@pytest.fixture
def quiz_study(make_study):
    study = make_study(slug="quiz", comprehension_check=True, comprehension_questions=QUESTIONS,
                       comprehension_attempts=3)
    study.screened_out_code = "SCREEN42"  # the outcome codes are set on the study, not through a spec
    study.save(update_fields=["screened_out_code"])
    return study


@pytest.fixture
def arrived(client, quiz_study, answer_for):
    """A Prolific participant who gave consent and read the instructions: on the comprehension step."""
    client.get(reverse("entry", args=[quiz_study.slug]), {"PROLIFIC_PID": "quiz1", "STUDY_ID": "S", "SESSION_ID": "X"})
    p = Participant.objects.get()
    for _ in range(2):
        step = flow.current_step(p)
        assert client.post(answer_url(p, step.index), answer_for(p, step)).status_code == 302
        p.refresh_from_db()
    assert flow.current_step(p).kind == StepKind.COMPREHENSION
    return p


def answer_url(p, step):
    return reverse("answer", args=[p.study.slug, p.token, step])


def step_url(p):
    return reverse("step", args=[p.study.slug, p.token])


def post(client, p, body, attempt):
    return client.post(answer_url(p, 2), {**body, "attempt": str(attempt)})


def test_the_check_stands_right_after_the_instructions_only_when_the_study_asks_it(study, quiz_study):
    plain = [s.kind for s in flow.steps_for(Participant(study=study, condition=study.conditions.first()))]
    asked = [s.kind for s in flow.steps_for(Participant(study=quiz_study, condition=quiz_study.conditions.first()))]
    assert StepKind.COMPREHENSION not in plain
    assert asked == plain[:2] + [StepKind.COMPREHENSION] + plain[2:]


def test_fail_read_again_then_pass(client, arrived):
    p = arrived
    page = client.get(step_url(p)).content.decode()
    assert "Questions about the instructions" in page and 'name="attempt" value="1"' in page
    assert post(client, p, WRONG, 1).status_code == 302
    p.refresh_from_db()
    assert p.position == 2 and not p.outcome
    again = client.get(step_url(p)).content.decode()
    # the instructions again, the missed question named, 2 tries left, and a way back to the questions
    assert 'id="instructions"' in again and 'id="missed"' in again and "What comes first?" in again
    assert "Which are colours?" not in again.split('id="missed"')[1].split("</section>")[0]
    assert "You have 2 more tries" in again and 'href="?questions=1"' in again
    questions = client.get(step_url(p), {"questions": "1"}).content.decode()
    assert 'name="attempt" value="2"' in questions and questions.count("question missed") == 1
    assert post(client, p, RIGHT, 2).status_code == 302
    p.refresh_from_db()
    assert p.position == 3 and flow.current_step(p).kind == StepKind.TRAINING
    attempts = list(p.comprehension_attempts.values_list("number", "missed", "passed"))
    assert attempts == [(1, [0], False), (2, [], True)]
    answer = Answer.objects.get(participant=p, kind=StepKind.COMPREHENSION)
    assert answer.step == 2 and answer.data == {"attempts": 2, "answers": [[1], [0, 2]]}


def test_the_page_never_says_which_answers_are_right(client, arrived):
    page = client.get(step_url(arrived)).content.decode()
    for q in QUESTIONS:  # each choice only by its position, all alike
        for choice in q["choices"]:
            assert choice in page
    assert "right" not in re.sub(r"<[^>]+>", "", page).lower().replace("tick every right answer", "")
    assert len(set(re.findall(r'<input type="(radio|checkbox)" name="q0" value="\d+">', page))) == 1


def test_an_unanswered_question_is_one_line_and_stores_nothing(client, arrived):
    r = post(client, arrived, {"q0": ["1"]}, 1)
    assert r.status_code == 400
    assert "Please answer every question: question 2 has no answer yet." in r.content.decode()
    assert not ComprehensionAttempt.objects.exists()


def test_a_replayed_post_is_counted_once(client, arrived):
    p = arrived
    for _ in range(3):  # a double click, then a retry of the same post
        assert post(client, p, WRONG, 1).status_code == 302
    assert p.comprehension_attempts.count() == 1
    p.refresh_from_db()
    assert not p.outcome
    changed = post(client, p, RIGHT, 1)  # the same attempt's page, other answers: out of date, nothing stored
    assert changed.status_code == 302 and "moved=1" in changed["Location"]
    assert p.comprehension_attempts.count() == 1
    assert post(client, p, RIGHT, 5).status_code == 302 and p.comprehension_attempts.count() == 1
    stale = client.post(answer_url(p, 2), {**RIGHT, "attempt": "5"}, HTTP_ACCEPT="application/json")
    assert stale.status_code == 409 and stale.json()["error"] == (
        "This page is out of date: it sent attempt 5 at the questions of step 3, and you are on attempt 2. "
        "Please answer on the current page.")
    assert post(client, p, RIGHT, 2).status_code == 302
    assert post(client, p, RIGHT, 2).status_code == 302  # passed, replayed: still one Answer, two attempts
    assert p.comprehension_attempts.count() == 2 and Answer.objects.filter(kind=StepKind.COMPREHENSION).count() == 1


def test_three_failures_screen_out_with_the_studys_code_and_prolifics_redirect(client, arrived):
    p = arrived
    for n in (1, 2, 3):
        assert post(client, p, WRONG, n).status_code == 302
    p.refresh_from_db()
    assert p.outcome == status.SCREENED_OUT and p.completion_code == "SCREEN42"
    assert p.comprehension_attempts.count() == 3
    page = client.get(step_url(p))
    text = page.content.decode()
    assert 'data-outcome="screened_out"' in text and "SCREEN42" in text
    assert "https://app.prolific.com/submissions/complete?cc=SCREEN42" in text
    assert post(client, p, WRONG, 3).status_code == 302  # a replay after the end counts nothing
    assert post(client, p, RIGHT, 4).status_code == 302
    assert p.comprehension_attempts.count() == 3 and not Answer.objects.filter(kind=StepKind.COMPREHENSION).exists()


def test_the_attempts_are_in_the_exports_and_their_dictionary(client, arrived, quiz_study):
    post(client, arrived, WRONG, 1)
    post(client, arrived, RIGHT, 2)
    long = list(csv.DictReader(io.StringIO(exports.long_csv(quiz_study))))
    rows = [r for r in long if r["kind"] == "comprehension"]
    assert [(r["step"], r["item"], r["comprehension_passed"]) for r in rows] == [("2", "1", "0"), ("2", "2", "1")]
    assert '"answers": [[0], [0, 2]]' in rows[0]["answer_json"] and '"missed": [0]' in rows[0]["answer_json"]
    assert [r["kind"] for r in long][:4] == ["consent", "instructions", "comprehension", "comprehension"]
    wide = next(csv.DictReader(io.StringIO(exports.wide_csv(quiz_study))))
    assert (wide["comprehension_attempts"], wide["comprehension_passed"]) == ("2", "1")
    described = {(r["file"], r["column"]): r["description"]
                 for r in csv.DictReader(io.StringIO(exports.dictionary_csv(quiz_study)))}
    for key in (("long", "comprehension_passed"), ("wide", "comprehension_attempts"), ("wide", "comprehension_passed")):
        assert described[key]


def test_a_study_without_the_check_keeps_its_export_columns(study, complete):
    complete(assignment.assign(study, "prolific", "P1"))
    header = exports.long_csv(study).splitlines()[0]
    assert "comprehension" not in header and "comprehension" not in exports.wide_csv(study).splitlines()[0]


def test_erasing_a_participant_removes_their_attempts(client, arrived):
    post(client, arrived, WRONG, 1)
    post(client, arrived, WRONG, 2)
    found = privacy.erase("quiz1")
    assert found.n_attempts == 2 and "2 comprehension attempt(s)" in found.summary()
    assert not ComprehensionAttempt.objects.exists()


def test_every_domain_asks_questions_it_can_check():
    for name in domain_names():
        asked = comprehension.defaults(get_domain(name))
        assert 2 <= len(asked) == len(comprehension.check(asked))


def test_the_designers_text_round_trips_and_bad_questions_are_one_line():
    assert comprehension.parse_text(comprehension.format_text(QUESTIONS)) == QUESTIONS
    for text, message in (("Q?\n- a\n- b", "question 1 has no right answer"),
                          ("Q?\n* a\n- b\n\nR?\n* only", "question 2 needs at least 2 choices"),
                          ("Q?\n* a\nb", "question 1: each choice starts with '* ' (right) or '- ' (wrong)")):
        with pytest.raises(comprehension.QuestionsError, match=re.escape(message)):
            comprehension.parse_text(text)


@pytest.mark.parametrize("change, message", [
    ({"comprehension_attempts": 0}, "the comprehension check's attempts must be a positive whole number up to 10"),
    ({"comprehension_attempts": 50}, "up to 10, not 50"),
    ({"comprehension_questions": "Q?\n- a\n- b"}, "the comprehension questions: question 1 has no right answer"),
])
def test_a_spec_refuses_bad_settings_in_one_line(tiny_table, change, message):
    from studyapp.researcher.studies import table_spec  # noqa: PLC0415
    from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET  # noqa: PLC0415

    spec = {**table_spec(tiny_table, slug="bad", sequences=SMALL_SEQUENCES, **TINY_TEST_SET),
            "comprehension_check": True, **change}
    with pytest.raises(SpecError, match=re.escape(message)) as raised:
        check_spec(spec)
    assert "\n" not in str(raised.value)


DESIGN = {"slug": "designed", "name": "Designed", "conditions": ["exact"], "target_per_condition": "20",
          "recruitment": "link", "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001",
          "estimated_minutes": "15", "comprehension_check": "on", "comprehension_attempts": "3",
          "min_distance": "0.1"}  # the tiny table has a test of every cluster at 0.1 (TINY_TEST_SET)


@pytest.fixture
def design(tiny_table):
    """A bound designer form on the tiny table (its robot's questions prefilled, as the page sends them)."""
    from precompute.design import StudyDesignForm  # noqa: PLC0415
    from precompute.tables import built_tables  # noqa: PLC0415

    tables = [t for t in built_tables(tiny_table.parent) if t["path"] == str(tiny_table)]
    text = StudyDesignForm(tables=tables).fields["comprehension_questions"].initial

    def bound(**change):
        return StudyDesignForm({**DESIGN, "table": str(tiny_table), "comprehension_questions": text, **change},
                               tables=tables)

    return bound


@pytest.mark.parametrize("change, field, message", [
    ({"comprehension_questions": "Q?\n- a\n- b"}, "comprehension_questions",
     "the comprehension questions: question 1 has no right answer: mark one with '* '"),
    ({"comprehension_questions": "Q?\n* a\n- b\n\nR?\n* only"}, "comprehension_questions",
     "the comprehension questions: question 2 needs at least 2 choices (got 1)"),
    ({"comprehension_attempts": "0"}, "comprehension_attempts",
     "the comprehension check's attempts must be a positive whole number up to 10, not 0"),
    ({"comprehension_attempts": "11"}, "comprehension_attempts",
     "the comprehension check's attempts must be a positive whole number up to 10, not 11"),
])
def test_the_designer_says_bad_comprehension_settings_in_one_line(design, change, field, message):
    form = design(**change)
    assert not form.is_valid()
    assert form.errors[field] == [message]


def test_the_designer_stores_the_robots_own_questions_empty_and_the_researchers_parsed(design, tiny_table):
    form = design()
    assert form.is_valid(), form.errors
    job = form.cleaned_data["job"]  # the design as the job's check stored it: empty is the robot's own
    assert (job["comprehension_check"], job["comprehension_questions"], job["comprehension_attempts"]) == (True, [], 3)
    own = design(comprehension_questions="Which?\n- no\n* yes", comprehension_attempts="2")
    assert own.is_valid(), own.errors
    stored = own.cleaned_data["job"]  # what the study job stores
    assert stored["comprehension_questions"] == [{"question": "Which?", "choices": ["no", "yes"], "right": [1]}]
    assert stored["comprehension_attempts"] == 2
    off = design(comprehension_check="", comprehension_questions="not a question at all\nb")
    assert off.is_valid(), off.errors  # questions of a check that is off are not asked, nor judged
