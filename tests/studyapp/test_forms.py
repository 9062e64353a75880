"""The step forms (studyapp.participant.forms) on their own, and StepKind as the one source of step kinds."""
import re
from pathlib import Path
from types import SimpleNamespace

import pytest
from django.http import QueryDict

from studyapp.models import Answer, StepKind
from studyapp.participant import flow
from studyapp.participant.forms import (
    AttentionForm,
    ConsentForm,
    DemographicsForm,
    InstructionsForm,
    TestForm,
    TrainingForm,
)
from studyapp.participant.pages import PAGES, SHOW_PAGES
from teaching.api import domain_names, get_domain

ROOT = Path(__file__).resolve().parents[2]
SHOWN = [("A", 2), ("B", 0), ("C", 3), ("D", 1)]  # letter -> option index, as flow.option_letters gives
# what AttentionForm and ConsentForm read
DRIVING_PARTICIPANT = SimpleNamespace(study=SimpleNamespace(domain="driving", consent_version=lambda: "0123456789ab"))


def post(**fields) -> QueryDict:
    q = QueryDict(mutable=True)
    for k, v in fields.items():
        q.setlist(k, v if isinstance(v, list) else [v])
    return q


def error(form) -> str | None:
    return None if form.is_valid() else form.first_error()


def test_stored_kind_strings_never_change():
    """Answer.kind holds these strings, the exports carry them and templates are named by them."""
    assert [k.value for k in StepKind] == [
        "consent", "instructions", "comprehension", "training", "check", "feedback", "test", "attention",
        "demographics", "done"]
    assert Answer._meta.get_field("kind").choices == StepKind.choices
    assert set(PAGES) == set(StepKind) and set(SHOW_PAGES) == {StepKind.TEST, StepKind.CHECK}
    assert [k for k, page in PAGES.items() if page.form is None] == [StepKind.DONE]  # the one page taking no answer


def test_step_kinds_come_only_from_step_kind():
    """No production module compares or stores a kind as a bare string literal."""
    kinds = "|".join(k.value for k in StepKind)
    literal = re.compile(rf"""kind\s*(==|!=|=)\s*["']({kinds})["']|\(["']({kinds})["'],\s*None\)""")
    files = [*ROOT.glob("studyapp/**/*.py"), ROOT / "config" / "gunicorn.conf.py", *ROOT.glob("precompute/**/*.py")]
    found = [f"{path.relative_to(ROOT)}: {line.strip()}" for path in files if "migrations" not in path.parts
             for line in path.read_text().splitlines() if literal.search(line)]
    assert found == []


def test_steps_of_a_participant_are_step_kinds(participant):
    assert all(isinstance(step.kind, StepKind) for step in flow.steps_for(participant))


@pytest.mark.parametrize("form_class, fields, message", [
    (ConsentForm, {}, "Please say whether you agree to take part."),
    (ConsentForm, {"consent": "no"}, "You can only continue if you agree to take part."),
    (ConsentForm, {"consent": ["yes", "yes"]}, "Please say whether you agree to take part."),  # sent twice
    (ConsentForm, {"consent": "  "}, "Please say whether you agree to take part."),
    (InstructionsForm, {"ack": ""}, "Please confirm that you have read the instructions."),
    (TrainingForm, {"played": "0"}, "Please watch the whole animation before you continue."),
    (TrainingForm, {"played": " 1"}, "Please watch the whole animation before you continue."),
    (AttentionForm, {}, "Please tick your answer."),
    (AttentionForm, {"goals": ["merge", ""]}, "Please tick only answers from the list."),
    (AttentionForm, {"goals": ["fly"]}, "Please tick only answers from the list."),
    (DemographicsForm, {"age": "30"}, "Please choose an answer for gender (or 'Prefer not to say')."),
    (DemographicsForm, {"age": "30", "gender": "robot"}, "Please choose an answer for gender from the list."),
    (DemographicsForm, {"age": "", "gender": "male"}, "Please enter your age."),
    (DemographicsForm, {"age": ["30", "31"], "gender": "male"}, "Please enter your age."),
    (DemographicsForm, {"age": "17", "gender": "male"}, "Your age must be a whole number from 18 to 120."),
    (DemographicsForm, {"age": "121", "gender": "male"}, "Your age must be a whole number from 18 to 120."),
    (DemographicsForm, {"age": "30.0", "gender": "male"}, "Your age must be a whole number from 18 to 120."),
    (DemographicsForm, {"age": "3e1", "gender": "male"}, "Your age must be a whole number from 18 to 120."),
    # digits int() reads but no page sends, and a number int() parses at length (studyapp.guards.inputs)
    (DemographicsForm, {"age": "٣٠", "gender": "male"}, "Your age must be a whole number from 18 to 120."),
    (DemographicsForm, {"age": "３０", "gender": "male"}, "Your age must be a whole number from 18 to 120."),
    (DemographicsForm, {"age": "0" * 5000 + "30", "gender": "male"}, "Your age must be a whole number from 18 to 120."),
    (DemographicsForm, {"gender": "robot"}, "Please choose an answer for gender from the list."),  # first field first
])
def test_each_bad_answer_gives_its_message(form_class, fields, message):
    assert error(form_class(post(**fields), DRIVING_PARTICIPANT, None)) == message


def test_good_answers_give_the_stored_data():
    consent = ConsentForm(post(consent=" yes "), DRIVING_PARTICIPANT, None)
    assert consent.is_valid() and consent.answer() == {"consent": True, "consent_version": "0123456789ab"}
    stale = ConsentForm(post(consent="yes", consent_version="ffffffffffff"), DRIVING_PARTICIPANT, None)
    assert error(stale).startswith("The study's information changed after this page was opened")
    assert InstructionsForm(post(ack="1"), None, None).is_valid()
    attention = AttentionForm(post(goals=["forward", "merge", "merge"]), DRIVING_PARTICIPANT, None)
    assert attention.is_valid() and attention.answer() == {"goals": ["forward", "merge"], "passed": True}


@pytest.mark.parametrize("domain, ticked, passed", [
    ("driving", ["merge", "forward"], True), ("driving", ["merge"], False),
    ("driving", ["merge", "forward", "exit"], False),
    ("gridworld", ["deliver"], True), ("gridworld", ["deliver", "clean"], False), ("gridworld", ["charge"], False)])
def test_the_attention_check_is_the_study_domains(domain, ticked, passed):
    form = AttentionForm(post(goals=ticked), SimpleNamespace(study=SimpleNamespace(domain=domain)), None)
    assert form.is_valid() and form.answer() == {"goals": sorted(ticked), "passed": passed}


def test_one_domains_answers_are_not_anothers():
    form = AttentionForm(post(goals=["deliver"]), DRIVING_PARTICIPANT, None)
    assert error(form) == "Please tick only answers from the list."
    demo = DemographicsForm(post(age=" 34 ", gender="other", gender_text=" x" * 80), None, None)
    assert demo.is_valid() and demo.answer() == {"age": 34, "gender": "other", "gender_text": ("x " * 80)[:100]}
    demo = DemographicsForm(post(age="34", gender="female", gender_text="ignored"), None, None)
    assert demo.is_valid() and demo.answer() == {"age": 34, "gender": "female"}


def make_test_form(domain="driving", **changes) -> TestForm:
    fields = {"played": ["A", "B", "C", "D"], "choice": "C", "rating_A": "1", "rating_B": "2", "rating_C": "7",
              "rating_D": "4", **changes}
    participant = SimpleNamespace(study=SimpleNamespace(domain=domain))
    return TestForm(post(**{k: v for k, v in fields.items() if v is not None}), participant, None, shown=SHOWN,
                    env_id=5)



@pytest.mark.parametrize("changes, message", [
    ({"played": ["A", "B", "C", "D", "E"]}, "This question has options A, B, C, D only; please reload the page."),
    ({"played": ["A", "C"]}, "Please play option B, D before you continue."),
    ({"played": None}, "Please play option A, B, C, D before you continue."),
    ({"choice": None}, "Please choose the option that matches the car's driving style."),
    ({"choice": ["A", "B"]}, "Please choose the option that matches the car's driving style."),
    ({"choice": "E"}, "This question has options A, B, C, D only; please choose one of them."),
    ({"rating_E": "3"}, "This question has options A, B, C, D only; please reload the page."),
    ({"rating_B": None}, "Please rate how well option B matches (1 = not at all, 7 = exactly)."),
    ({"rating_B": "0"}, "The rating of option B must be a whole number from 1 to 7."),
    ({"rating_B": "8"}, "The rating of option B must be a whole number from 1 to 7."),
    ({"rating_B": "6.0"}, "The rating of option B must be a whole number from 1 to 7."),
    ({"rating_B": "٦"}, "The rating of option B must be a whole number from 1 to 7."),
    ({"rating_B": "²"}, "The rating of option B must be a whole number from 1 to 7."),
    # several problems: the participant is told the first, in the page's order
    ({"played": ["A"], "choice": "E", "rating_A": "9"}, "Please play option B, C, D before you continue."),
    ({"choice": "E", "rating_E": "3"}, "This question has options A, B, C, D only; please choose one of them."),
    ({"rating_E": "3", "rating_A": "9"}, "This question has options A, B, C, D only; please reload the page."),
])
def test_each_bad_test_answer_gives_its_message(changes, message):
    assert error(make_test_form(**changes)) == message


@pytest.mark.parametrize("domain", domain_names())
def test_a_test_without_a_choice_is_refused_in_the_study_domains_words(domain):
    texts = get_domain(domain).texts
    for missing in ({"choice": None}, {"choice": ["A", "B"]}):
        assert error(make_test_form(domain, **missing)) == texts.choice_required


def test_the_yard_is_not_asked_about_the_car():
    message = error(make_test_form("gridworld", choice=None))
    assert message == "Please choose the delivery that matches the robot's preferences."
    assert not re.search(r"\b(cars?|driv\w*)\b", message.lower())


def test_ratings_are_stored_by_option_index(participant):
    step = next(s for s in flow.steps_for(participant) if s.kind == StepKind.TEST)
    shown = flow.option_letters(participant, step.item)
    ratings = {f"rating_{letter}": str(k + 1) for letter, k in shown}
    form = TestForm(post(played=[letter for letter, _ in shown], choice=shown[0][0], **ratings), participant, step,
                    shown=shown, env_id=participant.study.test_set[step.item]["env_id"])
    assert form.is_valid(), form.errors
    assert form.answer() == {"env_id": participant.study.test_set[step.item]["env_id"], "choice": shown[0][1],
                             "ratings": [1, 2, 3, 4], "order": participant.option_orders[step.item]}
