"""One schema for a study spec (studyapp/researcher/specschema.py): a JSON spec (create_study), the study job
(build_study and the designer's job) and the designer's form refuse the same bad input with the same
one-line message, because each checks it against the same declared field; a rule changed in the
schema changes all three; the spec's fields in docs/study.md are the schema's."""
from __future__ import annotations

import io
import json
import re
from dataclasses import replace
from pathlib import Path

import pytest
from django.core.management import call_command
from django.core.management.base import CommandError

from precompute.design import StudyDesignForm, schema_field
from precompute.models import Job
from precompute.study import StudyJobError, create_study_job
from precompute.tables import built_tables
from studyapp.models import Study
from studyapp.researcher import specschema
from studyapp.researcher.specschema import (
    CONDITION_FIELDS,
    JOB_FIELDS,
    SPEC_FIELDS,
    STUDY_FIELDS,
    THRESHOLD_FIELDS,
    SpecError,
    check_job,
)
from studyapp.researcher.studies import build_study, table_spec
from teaching.api import selector_names
from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET

pytestmark = pytest.mark.django_db
ROOT = Path(__file__).resolve().parents[2]

FORM = {"slug": "designed", "conditions": ["random"], "target_per_condition": "20", "recruitment": "link",
        "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001", "estimated_minutes": "15",
        "min_distance": "0.1"}  # the tiny table has a test of every cluster at 0.1 (TINY_TEST_SET)
LONG_CODE = "C" * 65

# (what is wrong, the spec's change, the job's arguments, the form's data, the form's field, the message);
# None where an entry point cannot be given that input (a form posts text; the job takes no theta*).
CASES = [
    ("negative target", {"target_per_condition": -3}, {"target_per_condition": -3}, {"target_per_condition": "-3"},
     "target_per_condition", "'target_per_condition' must be a positive whole number up to 100,000, not -3"),
    ("condition name not a slug", {"conditions": [{"name": "my condition!", "env_ids": [500, 5780]}]},
     {"hand_picked": {"my condition!": [500]}}, {"hand_picked_name": "my condition!", "hand_picked_env_ids": "500"},
     "hand_picked_name", "condition name 'my condition!' may hold only letters, digits, - and _ (or be "
                         "coverage-approx*)"),
    ("slug not a slug", {"slug": "bad slug"}, {"slug": "bad slug"}, {"slug": "bad slug"}, "slug",
     "'slug' may hold only letters, digits, - and _, not 'bad slug'"),
    ("completion code too long", {"completion_code": LONG_CODE}, {"completion_code": LONG_CODE},
     {"completion_code": LONG_CODE}, "completion_code", "'completion_code' must be at most 64 characters long, not 65"),
    ("unknown recruitment", {"recruitment": "facebook"}, {"recruitment": "facebook"}, {"recruitment": "facebook"},
     "recruitment", "'recruitment' must be one of link, prolific, mturk, not 'facebook'"),
    ("no minutes", {"estimated_minutes": 0}, {"estimated_minutes": 0}, {"estimated_minutes": "0"},
     "estimated_minutes", "'estimated_minutes' must be a positive whole number, not 0"),
    ("negative threshold", None, {"test_set_thresholds": {"min_distance": -1.0}}, {"min_distance": "-1"},
     "min_distance", "test-set threshold 'min_distance' must be a number, 0 or more, not -1.0"),
    ("unknown threshold", None, {"test_set_thresholds": {"max_regret": 0.1}}, None, None,
     "'test_set_thresholds' takes min_regret and min_distance, not 'max_regret'"),
    ("negative seed", None, {"seed": -1}, {"seed": "-1"}, "seed", "'seed' must be a whole number, 0 or more, not -1"),
    ("completion code not a string", {"completion_code": 5}, {"completion_code": 5}, None, None,
     "'completion_code' must be a string, not 5"),
    ("theta* not numbers", {"theta_star": ["-64", -0.1]}, None, None, None,
     "'theta_star' must be a list of numbers, one per feature, not ['-64', -0.1]"),
    ("unknown selector", {"conditions": [{"name": "mine", "selector": "greedy", "env_ids": [500, 5780]}]},
     {"conditions": [{"name": "mine", "selector": "greedy"}]}, None, None,
     f"condition 'mine': unknown selector 'greedy'; choose from {', '.join(selector_names())}"),
    ("bad selector parameter",
     {"conditions": [{"name": "highlights", "selector": "highlights", "params": {"k": 0}, "env_ids": [500, 5780]}]},
     {"conditions": [{"selector": "highlights", "params": {"k": 0}}]},
     {"conditions": ["highlights"], "highlights_k": "0"},
     "highlights_k", "condition 'highlights': selector 'highlights': parameter 'k': must be an integer >= 1, got 0"),
    ("unknown selector parameter",
     {"conditions": [{"name": "scot", "selector": "scot", "params": {"k": 2}, "env_ids": [500, 5780]}]},
     {"conditions": [{"selector": "scot", "params": {"k": 2}}]}, None, None,
     "condition 'scot': selector 'scot': unknown parameter 'k'; it takes no parameters"),
    ("parameters without a selector", {"conditions": [{"name": "mine", "params": {"k": 2}, "env_ids": [500, 5780]}]},
     None, None, None, "condition 'mine': 'params' needs the 'selector' they are for"),
    ("unknown test difficulty", None, {"test_difficulty": "hard"}, {"test_difficulty": "hard"}, "test_difficulty",
     "'test_difficulty' must be one of none, low, medium, high, not 'hard'"),
]


def spec(tiny_table, slug="bad"):
    return table_spec(tiny_table, slug=slug, sequences=SMALL_SEQUENCES, **TINY_TEST_SET)


def design_form(tiny_table, change: dict) -> StudyDesignForm:
    tables = [t for t in built_tables(tiny_table.parent) if t["path"] == str(tiny_table)]
    return StudyDesignForm({**FORM, "table": str(tiny_table), **change}, tables=tables)


def spec_error(tiny_table, tmp_path, change: dict) -> str:
    """The create_study command's one line for the spec with `change`."""
    path = tmp_path / "spec.json"
    path.write_text(json.dumps({**spec(tiny_table), **change}))
    with pytest.raises(CommandError) as caught:
        call_command("create_study", str(path), stdout=io.StringIO())
    return str(caught.value)


def job_error(tiny_table, args: dict) -> str:
    """The study job's one line for these arguments: its check's (a field's own rule) or, past it, the
    job's (what needs the table or the database)."""
    with pytest.raises((SpecError, StudyJobError)) as caught:
        create_study_job(tiny_table, check_job({"slug": "bad", "conditions": ["random"], **args}), start=False)
    return str(caught.value)


def form_errors(tiny_table, change: dict, field: str) -> list[str]:
    form = design_form(tiny_table, change)
    assert not form.is_valid()
    return form.errors.get(field, [])


def test_the_unchanged_inputs_are_accepted(tiny_table):
    """The baseline each case below changes one thing of: every entry point takes it."""
    assert design_form(tiny_table, {}).is_valid()
    assert create_study_job(tiny_table, check_job({"slug": "job-ok", "conditions": ["random"]}), start=False
                            ).params["slug"] == "job-ok"
    assert build_study(spec(tiny_table, "spec-ok")).slug == "spec-ok"


@pytest.mark.parametrize("what, spec_change, job_args, form_change, field, message", CASES, ids=[c[0] for c in CASES])
def test_every_entry_point_refuses_a_bad_input_in_the_schemas_words(tiny_table, tmp_path, what, spec_change,
                                                                     job_args, form_change, field, message):
    if spec_change is not None:
        assert spec_error(tiny_table, tmp_path, spec_change) == message
    if job_args is not None:
        assert job_error(tiny_table, job_args) == message
    if form_change is not None:
        assert form_errors(tiny_table, form_change, field) == [message]
    assert not Study.objects.exists() and not Job.objects.exists()


def test_a_spec_records_its_conditions_selectors_and_refuses_a_test_of_an_unknown_difficulty(tiny_table, tmp_path):
    conditions = [{"name": "top", "selector": "highlights", "params": {"k": 2}, "env_ids": [500, 5780]},
                  {"name": "paper", "selector": "coverage-approx*", "env_ids": [7107]}]
    study = build_study({**spec(tiny_table, "recorded"), "conditions": conditions})
    assert study.source["selectors"] == {
        "top": {"selector": "highlights", "params": {"k": 2}},
        "paper": {"selector": "coverage-approx*", "params": {"model": "det-euclidean"}}}
    tests = spec(tiny_table)["test_set"]
    graded = [{**t, "difficulty": "medium"} for t in tests]
    assert build_study({**spec(tiny_table, "graded"), "test_set": graded}).test_set[0]["difficulty"] == "medium"
    tests[2]["difficulty"] = "hard"
    assert spec_error(tiny_table, tmp_path, {"test_set": tests}) == \
        "test 2: 'difficulty' must be one of low, medium, high, not 'hard'"


def test_the_designer_says_every_bad_value_at_once_under_its_field(tiny_table):
    form = design_form(tiny_table, {"target_per_condition": "0", "seed": "-1", "min_regret": "-0.5"})
    assert not form.is_valid()
    assert set(form.errors) == {"target_per_condition", "seed", "min_regret"}
    assert "job" not in form.cleaned_data  # no job arguments from a bad form


def test_the_designers_fields_are_the_schemas(tiny_table):
    """Bounds, choices, defaults and help of every designer field that is a spec field come from the
    schema (precompute/design.py writes none of its own)."""
    form = StudyDesignForm(tables=[])
    # phones and tablets are the designer's one choice of devices (precompute/design.py device_arguments)
    pairs = {name: STUDY_FIELDS[name] for name in STUDY_FIELDS if name not in ("allow_phones", "allow_tablets")} | {
        name: JOB_FIELDS[name] for name in ("conditions", "approx_star", "seed")} | {
        name: THRESHOLD_FIELDS[name] for name in THRESHOLD_FIELDS} | {
        "hand_picked_name": CONDITION_FIELDS["name"], "loop_name": CONDITION_FIELDS["name"]}
    for name, declared in pairs.items():
        field = form.fields[name]
        assert getattr(field, "min_value", None) == declared.minimum, name
        assert getattr(field, "max_value", None) == declared.maximum, name
        assert getattr(field, "max_length", None) == declared.max_length, name
        if declared.choices:
            assert list(field.choices) == declared.choice_pairs, name
        if name != "loop_name":  # the designer's closed loop is an option of its own, and says so
            assert field.help_text.startswith(declared.help), name
    assert form.fields["target_per_condition"].min_value == 1 and form.fields["target_per_condition"].initial == 30


def test_a_rule_changed_in_the_schema_changes_every_entry_point(tiny_table, tmp_path, monkeypatch):
    """The rule lives in one place: make the smallest target 5 there, and the spec (the study's target and a
    condition's own), the job and the designer all refuse 3, in the same words, and the designer's field
    shows the new bound."""
    stricter = replace(STUDY_FIELDS["target_per_condition"], minimum=5)
    monkeypatch.setitem(STUDY_FIELDS, "target_per_condition", stricter)
    message = "'target_per_condition' must be a whole number from 5 to 100,000, not 3"
    assert spec_error(tiny_table, tmp_path, {"target_per_condition": 3}) == message
    assert job_error(tiny_table, {"target_per_condition": 3}) == message
    assert form_errors(tiny_table, {"target_per_condition": "3"}, "target_per_condition") == [message]
    conditions = [{"name": "alpha", "env_ids": [500, 5780], "target": 3}]
    assert spec_error(tiny_table, tmp_path, {"conditions": conditions}) == \
        "condition 'alpha': 'target' must be a whole number from 5 to 100,000, not 3"
    assert schema_field(STUDY_FIELDS["target_per_condition"]).min_value == 5


def test_the_designer_hands_the_job_the_design_its_check_made(tiny_table):
    """What the designer hands create_study_job is the CheckedStudy the job's own check made of its fields,
    built closed, and the table it picked."""
    form = design_form(tiny_table, {"hand_picked_name": "mine", "hand_picked_env_ids": "500, 5780",
                                    "fixed_det_euclidean": "0.5", "min_distance": "0.1"})
    assert form.is_valid(), form.errors
    checked = form.cleaned_data["job"]
    assert isinstance(checked, specschema.CheckedStudy) and form.cleaned_data["table"] == str(tiny_table)
    assert checked["hand_picked"] == {"mine": [500, 5780]} and checked["hyperparameters"] == {"det-euclidean": 0.5}
    assert checked["test_set_thresholds"] == {"min_regret": 0.001, "min_distance": 0.1}
    assert checked["is_open"] is False and checked["replace"] is False


def doc_section(heading: str) -> str:
    text = (ROOT / "docs" / "study.md").read_text()
    start = text.index(heading)
    return text[start:text.index("\n#", start + 1)]


def table_names(text: str) -> set[str]:
    """The `names` in the first column of a Markdown table's rows."""
    cells = re.findall(r"^\|([^|]+)\|", text, flags=re.M)
    return {name for cell in cells for name in re.findall(r"`([a-z_]+)`", cell)}


def test_every_spec_field_is_documented_and_every_documented_one_is_in_the_schema():
    section = doc_section("### A spec's fields")
    study, condition = section.split("**A condition's fields**")
    assert table_names(study) == set(STUDY_FIELDS) | set(SPEC_FIELDS)
    assert table_names(condition) == set(CONDITION_FIELDS)
